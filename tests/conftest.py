"""One headless GL context for the whole session; every GL test checks ctx.error around it."""

import pytest

from cavesim.gpu.gl.context import create_context

pytest_plugins = ["requirements"]  # @pytest.mark.requires(...) and --require-tools


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under pytest-xdist's --dist loadgroup (deploy/test.sh), which hands tests out one at
    a time, the slow tests first, each tier in its collected order: the longest then start
    while every worker is free, rather than one of them running alone at the end. (--dist
    load hands out runs of consecutive tests: there it would give one worker all of them.)"""
    # the workers collect; pytest-xdist sets their `loadgroup` option under --dist loadgroup
    if getattr(config.option, "loadgroup", False):
        items.sort(key=lambda item: item.get_closest_marker("slow") is None)


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
