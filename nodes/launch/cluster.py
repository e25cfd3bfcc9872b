"""A whole cluster on this machine: one node process per wall and the master in this
process, for `cavesim run`, `cavesim check` and `cavesim bench --cluster` alike. With
credentials, each node gets its own wall's key (and a preview an operator's key of its name
too), issued by the master's key for this run into a private temporary folder (mode 0700,
removed when the cluster stops): never the master's signing key, and no secret in OUT.

The master runs here so that a caller can act between frames (the consistency harness
kills, restarts and forges) and gets the run's `RunRecord` itself; a node process that
exits while the run needs it ends the run at once with that node's own error line. The
master logs into OUT/logs/master.log beside the nodes' logs, not onto the terminal.
"""

from __future__ import annotations

import dataclasses
import logging
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from cavesim.core.wire.key_files import write_member_keys
from cavesim.core.wire.network import NetworkSettings
from nodes.launch.launcher import LocalCluster
from nodes.master.link import ZenohMasterLink, open_master_link
from nodes.master.process import MasterConfig, run_master
from nodes.master.run_record import RunRecord


@dataclass(frozen=True)
class ClusterPlan:
    master: MasterConfig  # walls, scene, frames, session, credentials, timing (network: here)
    out: Path  # logs/<wall>.log of the node processes
    node_args: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # per wall
    drawing: frozenset[str] = frozenset()  # walls whose nodes draw pictures
    operators: frozenset[str] = frozenset()  # nodes that get an operator's key too (a preview)


def run_cluster(plan: ClusterPlan,
                progress: Callable[[int, int], None] = lambda k, live: None,
                before_frame: Callable[[LocalCluster, int], None] | None = None,
                checkpoint: Callable[[RunRecord], None] | None = None,
                on_link: Callable[[ZenohMasterLink], None] = lambda link: None) -> RunRecord:
    """Start a node per wall, run the master to the end (or Ctrl-C), stop every node
    (interrupted: at once, as a node still starting never took the STOP); `checkpoint` gets
    the record after every frame, `on_link` the master's link once it is open (what it
    refused so far, while the run goes: the harness waits on it)."""
    with started_cluster(plan) as (cluster, config):
        with open_master_link(config) as link, cluster.watch(link.events):
            on_link(link)
            hook = None if before_frame is None else (lambda k: before_frame(cluster, k))
            record = run_master(config, link, progress, hook, checkpoint)
        if record.interrupted:
            cluster.stop(at_once=True)
        return record


@contextmanager
def started_cluster(plan: ClusterPlan) -> Iterator[tuple[LocalCluster, MasterConfig]]:
    """The plan's node processes, started (and stopped at the end), and the master's config
    with the endpoint they connect to; the master's log goes to OUT/logs/master.log."""
    config = plan.master
    with _member_keys(config, plan.operators) as keys, \
            LocalCluster(config.scene, plan.out, config.session, keys=keys,
                         operators=plan.operators, expected_nodes=len(config.walls),
                         drawing=plan.drawing) as cluster:
        for wall in config.walls:
            cluster.start_node(wall, extra=plan.node_args.get(wall, ()))
        config = dataclasses.replace(config, network=NetworkSettings(
            listen=(cluster.master_endpoint,)))
        with _master_log(cluster.log_path("master")):
            yield cluster, config


@contextmanager
def _member_keys(config: MasterConfig, operators: frozenset[str] = frozenset()
                 ) -> Iterator[Path | None]:
    """A private folder with a key of each wall and of each of `operators`, issued by the
    master's credentials (None without credentials); removed at the end."""
    if config.credentials is None:
        yield None
        return
    with tempfile.TemporaryDirectory(prefix="cavesim-keys-") as folder:  # mode 0700
        keys = Path(folder)
        write_member_keys(keys, config.credentials, config.walls, operators=tuple(operators))
        yield keys


@contextmanager
def _master_log(path: Path) -> Iterator[None]:
    """cavesim's log records of this process go to `path` (INFO and up), not the terminal."""
    logger = logging.getLogger("cavesim")
    path.parent.mkdir(parents=True, exist_ok=True)
    handler = logging.FileHandler(path)
    handler.setFormatter(logging.Formatter("%(asctime)s %(name)s %(levelname)s %(message)s"))
    saved = logger.level, logger.propagate
    logger.setLevel(logging.INFO)
    logger.propagate = False
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        handler.close()
        logger.setLevel(saved[0])
        logger.propagate = saved[1]
