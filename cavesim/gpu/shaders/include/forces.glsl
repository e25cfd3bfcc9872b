// The forces on a particle: a = (u(p) + u_t - v) lambda + g - k v, each term compiled in
// only where the scene has its feature (HAS_DRAG with HAS_SCHILLER_NAUMANN and
// HAS_DISPERSION, HAS_GRAVITY, HAS_DAMPING), and -2 Omega x v (HAS_CORIOLIS); and the
// linear parts the exponential integrators hold over a step. Twins: cavesim/core/twin/forces.py (float64) and
// cavesim/core/portable/forces.py (portable arithmetic).
#pragma once
#include "arithmetic.glsl"

#if HAS_GRAVITY
uniform vec3 gravity;
#endif
#if HAS_DAMPING
uniform float damping;  // k of a = -k v, 1/s
#endif
#if HAS_CORIOLIS
uniform vec3 frame_rotation;  // Omega, rad/s: the rotation of the frame the scene is in

// -2 Omega x v: the Coriolis acceleration of a particle moving at v in that frame
vec3 coriolis(vec3 v) {
    vec3 turn = f_sub(f_mul(frame_rotation.yzx, v.zxy), f_mul(frame_rotation.zxy, v.yzx));
    return f_mul(-2.0, turn);
}
#endif
#if HAS_DRAG
#if FIELD_IS_ROTOR
#include "rotor.glsl"
#else
#include "field.glsl"
#endif
uniform float inv_tau[CLASS_COUNT];  // 1 / Stokes relaxation time per particle class

float inverse_relaxation_time(uint class_id) {
    return inv_tau[min(class_id, uint(CLASS_COUNT - 1))];
}
#else
float inverse_relaxation_time(uint class_id) {
    return 0.0;
}
#endif

// The particle being stepped, set by advance() before integrate() and read by each
// acceleration() and linear_parts() of its step (the twin's ForceModel holds the same)
#if HAS_SCHILLER_NAUMANN
// d / nu per class (0: a Stokes class), four to a vec4: an array element takes a vec4's
// room of the uniform storage, and a second per-class float array would overrun the
// 512 components a GL 4.3 compute stage must offer at 64 classes
uniform vec4 reynolds_per_speed[(CLASS_COUNT + 3) / 4];
float step_reynolds_per_speed;  // Re = this * |u - v|
#endif
#if HAS_DISPERSION
vec3 step_turbulence;  // dispersion.glsl: what the particle sees besides u(p) this step
#endif

#if HAS_DRAG
// Schiller & Naumann: C_D = 24/Re (1 + 0.15 Re^0.687) (cavesim/core/drag.py), constants
// as exact bits (cavesim/core/portable/constants.py)
#define SCHILLER_NAUMANN_COEFFICIENT uintBitsToFloat(0x3E19999Au)  // 0.15
#define SCHILLER_NAUMANN_EXPONENT uintBitsToFloat(0x3F2FDF3Bu)  // 0.687

// lambda, the rate at which drag relaxes the slip u - v: 1/tau (Stokes), times
// 1 + 0.15 Re^0.687 for a Schiller-Naumann class
float drag_rate(vec3 slip, float inv_tau_p) {
#if HAS_SCHILLER_NAUMANN
    float reynolds = f_mul(f_length(slip), step_reynolds_per_speed);
    if (reynolds > 0.0) {
        float wake = f_mul(SCHILLER_NAUMANN_COEFFICIENT,
                           f_pow(reynolds, SCHILLER_NAUMANN_EXPONENT));
        return f_mul(inv_tau_p, f_add(1.0, wake));
    }
#endif
    return inv_tau_p;
}

// The flow drag pulls toward: u(p), and with dispersion the turbulence seen this step
vec3 seen_flow(vec3 u) {
#if HAS_DISPERSION
    return f_add(u, step_turbulence);
#else
    return u;
#endif
}
#endif

// a = (u(p) + u_t - v) lambda + g - k v   (Kolb et al.: drag toward the flow texture;
// lambda = 1/tau for Stokes drag, from the slip u(p) - v for Schiller-Naumann's), with the
// flow at the step's `stage`
vec3 acceleration(vec3 p, vec3 v, float inv_tau_p, int stage) {
    vec3 a = vec3(0.0);
#if HAS_DRAG
    vec3 u = flow_at(p, stage);
    a = f_add(a, f_mul(f_sub(seen_flow(u), v), drag_rate(f_sub(u, v), inv_tau_p)));
#endif
#if HAS_GRAVITY
    a = f_add(a, gravity);
#endif
#if HAS_DAMPING
    a = f_sub(a, f_mul(damping, v));
#endif
#if HAS_CORIOLIS
    a = f_add(a, coriolis(v));
#endif
    return a;
}

// The forcing f = (u + u_t) lambda_d + g of dv/dt = f - lambda v where the flow is u, for
// the drag rate lambda_d (u and lambda_d unused without drag)
vec3 forcing(vec3 u, float drag) {
    vec3 f = vec3(0.0);
#if HAS_DRAG
    f = f_add(f, f_mul(seen_flow(u), drag));
#endif
#if HAS_GRAVITY
    f = f_add(f, gravity);
#endif
    return f;
}

// What the linear part -(held + k) v leaves of the acceleration at (p, v), its drag rate
// `held` taken at the step's start: (u + u_t) lambda_d + g - (lambda_d - held) v with
// lambda_d the rate at (p, v) itself (= held for Stokes drag), the flow at the step's end.
// ETD2RK's second stage (twin: ForceModel.remainder).
vec3 remainder_at(vec3 p, vec3 v, float held, float inv_tau_p) {
#if HAS_DRAG
    vec3 u = flow_at(p, STAGE_END);
    float drag = drag_rate(f_sub(u, v), inv_tau_p);
    vec3 remainder = forcing(u, drag);
#if HAS_SCHILLER_NAUMANN
    remainder = f_sub(remainder, f_mul(f_sub(drag, held), v));
#endif
#else
    vec3 remainder = forcing(vec3(0.0), held);
#endif
#if HAS_CORIOLIS  // not in the linear part: held explicitly, as the flow is
    remainder = f_add(remainder, coriolis(v));
#endif
    return remainder;
}

// a = f - lambda v with the flow and the drag rate held at their values at (p, v) at the
// step's start: the forcing f and lambda = lambda_d + k. Returns the drag rate lambda_d it
// held.
float linear_parts(vec3 p, vec3 v, float inv_tau_p, out vec3 f, out float lambda) {
    vec3 u = vec3(0.0);
    float drag = 0.0;
#if HAS_DRAG
    u = flow_at(p, STAGE_START);
    drag = drag_rate(f_sub(u, v), inv_tau_p);
#endif
    f = forcing(u, drag);
#if HAS_CORIOLIS
    f = f_add(f, coriolis(v));
#endif
    lambda = drag;
#if HAS_DAMPING
    lambda = f_add(lambda, damping);
#endif
    return drag;
}
