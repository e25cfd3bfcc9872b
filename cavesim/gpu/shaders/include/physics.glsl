// One frame of one particle: the step both engine paths' particle passes share. It is
// composed of the features' code, each in its include and compiled in only where the scene
// has the feature (cavesim/core/features/: forces.glsl for gravity, drag and damping,
// field.glsl or rotor.glsl for the flow, tracers.glsl, collision.glsl, dispersion.glsl),
// one INTEGRATOR (integrators.glsl). Every float operation goes through arithmetic.glsl
// (f_add, f_mul, ...): plain operators for ARITHMETIC_NATIVE, the same bits on every GPU
// for ARITHMETIC_PORTABLE, mirrored operation by operation in float32 by
// cavesim/core/portable/; cavesim/core/twin/ holds the float64 twin of every line.
#pragma once
#include "arithmetic.glsl"
#include "position.glsl"
#include "counters.glsl"

// where in its step an integrator takes the flow (a time-series field moves between them);
// the feature ids (INTEGRATOR_RK4, COLLISION_PLANE, ...) and an #error for every
// combination of features no scene can make come before this file, from the features'
// tables (cavesim/gpu/engine/programs.py: PASS_PREAMBLE)
#define STAGE_START 0
#define STAGE_MIDDLE 1
#define STAGE_END 2

uniform float dt;

#include "forces.glsl"

#include "integrators.glsl"
#include "tracers.glsl"
#include "collision.glsl"

#if HAS_DISPERSION
#include "dispersion.glsl"
#endif

// Beyond RUNAWAY a state is lost to overflow; a velocity beyond SPEED_LIMIT is one float32
// cannot step (cavesim/core/limits.py says why). Such a particle is dropped, never stored.
const float RUNAWAY = 1e15;
const float SPEED_LIMIT = 1e7;

// Every component of x below `limit`, compared as bits: the magnitude bits of non-negative
// floats order as their values, and NaN and Inf lie above every finite one. A driver may
// fold isnan() to false (GLSL does not require NaNs) or treat float compares with NaN
// loosely; integer compares are exact.
bool below(vec3 x, float limit) {
    uvec3 magnitude = floatBitsToUint(x) & uvec3(0x7FFFFFFFu);
    return all(lessThan(magnitude, uvec3(floatBitsToUint(limit))));
}

bool finite(vec3 x) {
    return below(x, RUNAWAY);
}

// One step of one particle's motion. Returns false when the particle starts or ends it
// faster than SPEED_LIMIT (a state written so; an unstable integrator, an absurd field) or
// its position ran away: the particle pass drops it, so NaN or Inf never reach the GPU
// state (a status, not a crash), and no stored velocity is one a step cannot take.
// `index`: the particle's place in the stream, the same on every node (its random draws).
bool advance(inout Particle q, float h, uint index) {
    bool steppable = below(q.vel, SPEED_LIMIT);
    float inv_tau_p = inverse_relaxation_time(q.class_id);
#if HAS_SCHILLER_NAUMANN
    uint drag_class = min(q.class_id, uint(CLASS_COUNT - 1));
    step_reynolds_per_speed = reynolds_per_speed[drag_class / 4u][drag_class % 4u];
#endif
#if HAS_DISPERSION
    step_turbulence = turbulence_seen(q.pos, q.vel, inv_tau_p, index, h);
#endif
    step_position_low = q.pos_low;
#if HAS_TRACERS
    if (is_tracer(q.class_id)) {
        trace(q.pos, q.vel, h);
    } else {
        integrate(q.pos, q.vel, inv_tau_p, h);
    }
#else
    integrate(q.pos, q.vel, inv_tau_p, h);
#endif
#if COLLISION != COLLISION_NONE
    collide(q.pos, q.vel);
#endif
    q.pos_low = step_position_low;
    return steppable && finite(q.pos) && below(q.vel, SPEED_LIMIT);
}

// One frame of the particle at `index` in the stream, the arithmetic both engine paths'
// particle passes share (GS/TF update.glsl, compute update_blocks.glsl): it ages by h
// and moves; with COUNT_DOMAIN_EXITS, a sane step from inside the field's box to outside
// it counts for the particle's class, with COUNT_GROUND_DEPOSITS one that lives on, on the
// ground.
// Returns whether it lives on: not expired and not run away. The age's float64 add stays
// outside arithmetic.glsl: portable only where the GPU rounds doubles as IEEE does.
bool step_particle(inout Particle q, float h, uint index) {
    q.age += double(h);
#if COUNT_DOMAIN_EXITS
    bool was_inside = !outside_field(field_coordinates(q.pos));
#endif
    bool sane = advance(q, h, index);
#if COUNT_DOMAIN_EXITS
    if (sane && was_inside && outside_field(field_coordinates(q.pos))) {
        count_add(DOMAIN_EXITS_AT + int(min(q.class_id, uint(CLASS_COUNT - 1))), 1u);
    }
#endif
    bool lives = q.age < double(q.lifetime) && sane;
#if COUNT_GROUND_DEPOSITS  // a census: each that lives on, on the ground after its step
    float ground;
    vec3 normal;
    ground_at(q.pos.xy, ground, normal);
    if (lives && q.pos.z <= ground) {
        count_add(GROUND_DEPOSITS_AT + int(min(q.class_id, uint(CLASS_COUNT - 1))), 1u);
    }
#endif
    return lives;
}
