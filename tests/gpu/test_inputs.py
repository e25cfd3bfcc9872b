"""Input checks at the engine's edges: the GL context, a frame's inputs, state uploads."""

import math

import moderngl
import numpy as np
import pytest
from scenes import make_scene

from cavesim.core.errors import ContextError
from cavesim.core.random_texture import draw_transform, random_words
from cavesim.gpu.engine import EMITTER_DTYPE, PARTICLE_DTYPE, FrameInput, ParticleSystem
from cavesim.gpu.gl import context
from cavesim.gpu.gl.devices import list_devices
from cavesim.gpu.gl.vendors import vendor_of


def test_a_context_that_does_not_open_names_the_fix_for_its_vendor(monkeypatch):
    def no_egl(**kwargs):
        raise Exception("libEGL.so.1: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_standalone_context", no_egl)
    with pytest.raises(ContextError) as error:
        context.create_context()
    assert "libEGL.so.1" in str(error.value)
    assert error.value.fix.startswith(vendor_of(list_devices()[0].extensions).fix)


def test_too_old_gl_names_the_version(monkeypatch):
    class OldContext:
        version_code = 330
        info = {"GL_VERSION": "3.3 (Core Profile) Mesa"}

        def release(self):
            pass

    monkeypatch.setattr(moderngl, "create_standalone_context", lambda **kw: OldContext())
    with pytest.raises(ContextError, match=r"OpenGL 4\.3 core is required.*'3\.3"):
        context.create_context()


@pytest.mark.parametrize("dt", [math.nan, math.inf, -math.inf, -0.01])
def test_bad_dt_is_rejected(dt):
    with pytest.raises(ValueError, match="dt must be finite and >= 0"):
        FrameInput(dt, np.eye(3))


@pytest.mark.parametrize(("matrix", "problem"), [
    (np.eye(4), "shape"),
    (np.eye(3) * 0.5, "integers"),
    (np.full((3, 3), np.nan), "integers"),
    (np.eye(3) * 2**25, "2\\*\\*24"),
    (np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1]]), "last row"),
])
def test_bad_random_transform_is_rejected(matrix, problem):
    with pytest.raises(ValueError, match=problem):
        FrameInput(1 / 60, matrix)


def test_frame_input_keeps_float32_bits():
    frame = FrameInput(1 / 60, np.eye(3))
    assert frame.dt.dtype == np.float32 and frame.random_transform.dtype == np.float32


def test_random_texture_depends_on_the_seed_only():
    assert np.array_equal(random_words(5, 64), random_words(5, 64))
    assert not np.array_equal(random_words(5, 64), random_words(6, 64))


def test_drawn_transforms_permute_the_lattice():
    rng = np.random.default_rng(0)
    size = 64
    y, x = np.mgrid[0:size, 0:size]
    points = np.stack([x.ravel(), y.ravel(), np.ones(size * size)]).astype(np.int64)
    for _ in range(20):
        matrix = draw_transform(rng, size)
        assert np.array_equal(matrix, np.round(matrix)) and np.array_equal(matrix[2], [0, 0, 1])
        moved = (matrix.astype(np.int64) @ points)[:2] % size
        assert len(np.unique(moved[0] * size + moved[1])) == size * size


def test_bad_state_uploads_are_rejected(ctx):
    system = ParticleSystem(ctx, make_scene(capacity=10))
    with pytest.raises(ValueError, match="11 records exceed the limit of 10"):
        system.write_particles(np.zeros(11, PARTICLE_DTYPE))
    with pytest.raises(ValueError, match="dtype"):
        system.write_particles(np.zeros(5, np.float32))
    system.begin_load(0)
    with pytest.raises(ValueError, match="1 records exceed the limit of 0"):
        system.commit_load(np.zeros(1, EMITTER_DTYPE))
    assert system.live_count == 0


def test_an_empty_stream_reads_as_an_empty_array(ctx):
    system = ParticleSystem(ctx, make_scene(capacity=0))
    system.step(FrameInput(1 / 60, np.eye(3)))
    assert len(system.read_particles()) == 0 and system.live_count == 0
