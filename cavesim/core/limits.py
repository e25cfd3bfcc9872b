"""Limits and defaults that more than one part of cavesim relies on, each written once.

The scene and CAVE schemas declare their bounds with these (`cavesim.core.scene.model`,
`cavesim.core.cave.geometry`); the engine's programs are specialized up to the scene limits and
the portability gate (`cavesim.gpu.shader_gate`) compiles every program at them; the command
line, the wire and the launcher use the rest. GL-free: the master imports it too.
"""

import re

# --- scenes: sizes every GL 4.3 driver can compile and run --------------------------------
# The engine's addressing bound on a scene's capacity, a bench run and a snapshot, whatever
# a driver allows (each GL context's own limits are read by cavesim.gpu.engine.capacity):
# moderngl 5.13 hands `transform(buffer_offset=)` to GL through a C int (parsed with "I",
# so a larger offset wraps without an error), and the emitter pass appends at survivors x
# 40-byte records. Vertex counts (GLsizei) and the checksum's uint word index reach further.
MAX_BYTE_OFFSET = 2**31 - 1
MAX_PARTICLES = MAX_BYTE_OFFSET // 40  # 53,687,091; 40 = PARTICLE_BYTES, asserted there
MAX_PARTICLE_CLASSES = 64  # one uniform float array: 256 components padded, GL 4.3 allows 512+
MAX_EMITTERS = 4096  # columns of the emitter table texture (GL 4.3: at least 16384)
RANDOM_TEXTURE_SIZE_RANGE = (16, 4096)  # a power of two; 4096 is below every GL 4.3 limit
FIELD_RESOLUTION_RANGE = (2, 256)  # nodes per axis: 256³ × 3 × float32 is already 200 MB
MAX_FIELD_NODES = 2**22  # nodes of a field in all: a 64 MiB RGBA32F texture at most
MAX_FIELD_SERIES_NODES = 2**25  # nodes of a time series' snapshots in all: 384 MiB of float32
# A series' snapshots are stacked along z in one 3D texture, 2 nodes deep each at least:
# 8192 of them fill the largest GL_MAX_3D_TEXTURE_SIZE we know of (16384, NVIDIA's; each
# context's own is checked when the texture is made). It bounds the grids a load makes.
MAX_FIELD_SNAPSHOTS = 8192

# --- what a scene may ask for ------------------------------------------------------------
MAX_RATE = 1e9  # particles/s of one emitter
MAX_LIFETIME = 3600.0  # s
MAX_DIAMETER = 0.1  # m: beyond this Stokes drag on a "particle" is meaningless
ROTOR_SPEED_RANGE = (0.0, 1.3)  # the wand's rotor speeds, fractions of hover (flight, drag)

# --- the CAVE and its processes -----------------------------------------------------------
NAME_RE = re.compile(r"[A-Za-z0-9_-]{1,32}")  # session and wall names: safe in zenoh keys
WALL_RESOLUTION_RANGE = (16, 8192)  # pixels per axis of one wall
GPU_RANGE = (0, 255)  # EGL device indices a wall (or `cavesim node --gpu`) may name
DEFAULT_MASTER_PORT = 7447  # deploy/launch.sh and config/ write it as a literal

# --- what a particle's state may hold (shaders/include/physics.glsl holds the same two) ---
# Past these the particle pass drops a particle, the same way on every node and in both
# twins. A component of the position at or beyond RUNAWAY is lost to overflow. SPEED_LIMIT
# bounds a velocity component before and after each step (an unstable integrator, an absurd
# field, a state written so): the drag step's increment v + h phi1 (f - lambda v) cancels
# to about 1e-7 of the speed in float32, so a particle at 1e14 m/s would leave one step at
# some 1e7 m/s, of either sign. No flow cavesim models comes near it (the brownout's wall
# jet: 30 m/s; the stability report's absurd field: 1e6 m/s).
RUNAWAY = 1e15
SPEED_LIMIT = 1e7  # m/s
MAX_LAUNCH_SPEED = SPEED_LIMIT / 4  # m/s, an emitter's speed: speed ± spread stays inside

MAX_TRAJECTORIES = 1_000_000  # particles a run may track (`cavesim run --trajectories`)

# --- input files: checked before what they hold is read ----------------------------------
# A file an input names (a scene, the files a scene names, a frame log, a key file) is read
# only if it is a regular file (not a FIFO, a device or a folder) of at most these bytes.
MAX_NESTING = 32  # levels of tables, objects and arrays in a TOML or JSON input (the
# shipped files reach 6)
MAX_TOML_BYTES = 2**24  # a scene, a CAVE, a tracker mapping or a key file: 16 MiB
MAX_FIELD_FILE_BYTES = 2**31  # a flow or height field (.npz, .nc, .vti): the largest series
# in float64 (805 MB) with room for other variables; the most of any file a scene names
MAX_FRAME_LOG_BYTES = 2**32  # read whole: some 25 million frames, four days at 60 Hz
MAX_FRAME_LOG_HEADER_BYTES = 2**20  # its JSON header line
MAX_MODEL_BYTES = 2**28  # a helicopter model (glTF): the file and its buffers together
MAX_MODEL_NODES = 2**14  # nodes of a model's glTF, and primitives drawn: half a second to walk
MAX_MODEL_TRIANGLES = 500_000  # of a model in all: 54 MB of rows
