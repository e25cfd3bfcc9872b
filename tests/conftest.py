"""One headless GL context for the whole session; every GL test checks ctx.error around it."""

import pytest

from cavesim.gpu.gl.context import create_context

pytest_plugins = ["requirements"]  # @pytest.mark.requires(...) and --require-tools


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The slow tests first, each tier in its collected order: under pytest-xdist's
    --dist loadgroup (deploy/test.sh) the longest then start while every worker is free,
    rather than one of them running alone at the end."""
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
