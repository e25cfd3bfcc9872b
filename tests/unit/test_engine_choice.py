"""The master's choice of one engine path for the nodes that probed theirs."""

from cavesim.core.scene.model import Engine
from cavesim.core.wire import InfoMessage
from nodes.master.engine_choice import EngineChoice

MEMBERS = ("front", "left", "right")


def info(node: str, engine: Engine, auto: bool = True) -> InfoMessage:
    return InfoMessage(0, node, 0, True, "llvmpipe", "Mesa", "4.5", engine=engine, auto=auto)


def test_probed_nodes_wait_for_every_member_then_all_step_with_the_most_chosen_path():
    choice = EngineChoice(MEMBERS)
    assert choice.described(info("front", Engine.COMPUTE), started=False) == []
    fixed = info("left", Engine.GS_TF, auto=False)
    assert choice.described(fixed, started=False) == [fixed]  # its own path: at once
    assert choice.welcome_engine(fixed) is None
    ready = choice.described(info("right", Engine.COMPUTE), started=False)
    assert [i.node for i in ready] == ["front", "right"] and choice.path is Engine.COMPUTE
    assert {choice.welcome_engine(i) for i in ready} == {Engine.COMPUTE}
    late = info("front", Engine.GS_TF)  # back after a crash, its probe now says otherwise
    assert choice.described(late, started=True) == [late]
    assert choice.welcome_engine(late) is Engine.COMPUTE


def test_a_tie_is_gs_tf_and_a_started_run_does_not_wait():
    tie = EngineChoice(("front", "left"))
    tie.described(info("front", Engine.COMPUTE), started=False)
    tie.described(info("left", Engine.GS_TF), started=False)
    assert tie.path is Engine.GS_TF
    started = EngineChoice(MEMBERS)
    assert [i.node for i in started.described(info("left", Engine.COMPUTE), True)] == ["left"]
    assert started.path is Engine.COMPUTE
