"""One headless GL context for the whole session; every GL test checks ctx.error around it.

Under pytest-xdist's --dist loadgroup (deploy/test.sh) it also orders the collection, slow
tests first, and makes sure each xdist_group mark reaches the scheduler."""

import pytest
from hypothesis import settings

from cavesim.gpu.gl.context import create_context

pytest_plugins = ["requirements"]  # @pytest.mark.requires(...) and --require-tools
# no per-example deadline: the property tests check what comes out, not how fast, and a
# shared machine under a parallel suite is slow at random
settings.register_profile("cavesim", deadline=None)
settings.load_profile("cavesim")


@pytest.hookimpl(trylast=True)  # after pytest-xdist's own, which names the groups
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under --dist loadgroup, which hands tests out one at a time, the slow tests first,
    each tier in its collected order: the longest then start while every worker is free,
    rather than one of them running alone at the end. (--dist load hands out runs of
    consecutive tests: there it would give one worker all of them.)"""
    # the workers collect; pytest-xdist sets their `loadgroup` option under --dist loadgroup
    if getattr(config.option, "loadgroup", False):
        for item in items:
            _join_group(item)
        items.sort(key=lambda item: item.get_closest_marker("slow") is None)


def _join_group(item: pytest.Item) -> None:
    """Give `item` the `@group` suffix by which the controller keeps an xdist_group on one
    worker. pytest-xdist 3.8 writes it to `_nodeid`, which pytest 9.2 no longer reads (its
    node ids are structured): without this every group is split, and its shared fixture
    made on each worker."""
    names = sorted({str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
                    for mark in item.iter_markers("xdist_group")})
    if not names:
        return
    suffix = "@" + "_".join(names)
    if not item.nodeid.endswith(suffix):
        from _pytest.nodeid import NodeId  # pytest >= 9.2, where the suffix goes missing

        item._id = NodeId.parse(item.nodeid + suffix)
    assert item.nodeid.endswith(suffix), f"{item.nodeid}: the group suffix did not stick"


@pytest.fixture(scope="session")
def gl_session():
    ctx = create_context()
    yield ctx
    ctx.release()


@pytest.fixture
def ctx(gl_session):
    assert gl_session.error == "GL_NO_ERROR", "a previous test left a GL error behind"
    yield gl_session
    assert gl_session.error == "GL_NO_ERROR"
    gl_session.extra["framebuffer"].use()
