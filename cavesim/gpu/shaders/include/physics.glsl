// The forces on a particle and the integrators that advance it by one step. Each scene
// compiles in only the forces it has (HAS_GRAVITY, HAS_DRAG, HAS_DAMPING), one
// INTEGRATOR and one COLLISION kind; cavesim/twin/ holds the float64 twin of every line.
#pragma once

#define INTEGRATOR_EXPLICIT_EULER 0
#define INTEGRATOR_SEMI_IMPLICIT_EULER 1
#define INTEGRATOR_TRAPEZOID 2
#define INTEGRATOR_VERLET 3
#define INTEGRATOR_RK2 4
#define INTEGRATOR_RK4 5
#define INTEGRATOR_EXPONENTIAL 6
#define COLLISION_NONE 0
#define COLLISION_PLANE 1
#define COLLISION_HEIGHTFIELD 2
#define OUT_OF_DOMAIN_CLAMP 0
#define OUT_OF_DOMAIN_ZERO 1
#define SAMPLING_MANUAL 0
#define SAMPLING_HARDWARE 1

uniform float dt;

#if HAS_GRAVITY
uniform vec3 gravity;
#endif
#if HAS_DAMPING
uniform float damping;  // k of a = -k v, 1/s
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

// a = (u(p) - v) / tau + g - k v   (Kolb et al.: Stokes drag toward the flow texture)
vec3 acceleration(vec3 p, vec3 v, float inv_tau_p) {
    vec3 a = vec3(0.0);
#if HAS_DRAG
    a += (flow_at(p) - v) * inv_tau_p;
#endif
#if HAS_GRAVITY
    a += gravity;
#endif
#if HAS_DAMPING
    a -= damping * v;
#endif
    return a;
}

// a = f - lambda v: the forcing f = u(p)/tau + g and the linear rate lambda = 1/tau + k
void linear_parts(vec3 p, float inv_tau_p, out vec3 f, out float lambda) {
    f = vec3(0.0);
    lambda = 0.0;
#if HAS_DRAG
    f += flow_at(p) * inv_tau_p;
    lambda += inv_tau_p;
#endif
#if HAS_GRAVITY
    f += gravity;
#endif
#if HAS_DAMPING
    lambda += damping;
#endif
}

#if INTEGRATOR == INTEGRATOR_EXPONENTIAL
// phi1(x) = (1 - e^-x) / x and phi2(x) = (x - 1 + e^-x) / x^2, by series where the closed
// forms cancel catastrophically in float32.
void exponential_weights(float x, out float e, out float phi1, out float phi2) {
    e = exp(-x);
    if (x < 0.5) {
        phi1 = 1.0 - x * (1.0 / 2.0 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0
               - x * (1.0 / 720.0 - x * (1.0 / 5040.0))))));
        phi2 = 1.0 / 2.0 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0
               - x * (1.0 / 720.0 - x * (1.0 / 5040.0 - x * (1.0 / 40320.0))))));
    } else {
        phi1 = (1.0 - e) / x;
        phi2 = (x - 1.0 + e) / (x * x);
    }
}
#endif

void integrate(inout vec3 p, inout vec3 v, float inv_tau_p, float h) {
#if INTEGRATOR == INTEGRATOR_EXPLICIT_EULER
    vec3 a = acceleration(p, v, inv_tau_p);
    p += h * v;
    v += h * a;
#elif INTEGRATOR == INTEGRATOR_SEMI_IMPLICIT_EULER
    // linearly implicit in the stiff drag and damping, explicit in the rest; the new
    // velocity moves the position. Stable for any tau: v' = (v + h f) / (1 + h lambda)
    vec3 f;
    float lambda;
    linear_parts(p, inv_tau_p, f, lambda);
    v = (v + h * f) / (1.0 + h * lambda);
    p += h * v;
#elif INTEGRATOR == INTEGRATOR_TRAPEZOID
    // UberFlow eq. (1)-(2): Euler velocity, position from the mean of old and new velocity
    vec3 v1 = v + h * acceleration(p, v, inv_tau_p);
    p += 0.5 * h * (v + v1);
    v = v1;
#elif INTEGRATOR == INTEGRATOR_VERLET
    // velocity Verlet; the drag's velocity dependence is met with an Euler-predicted velocity
    vec3 a0 = acceleration(p, v, inv_tau_p);
    p += h * v + (0.5 * h * h) * a0;
    vec3 a1 = acceleration(p, v + h * a0, inv_tau_p);
    v += (0.5 * h) * (a0 + a1);
#elif INTEGRATOR == INTEGRATOR_RK2
    // explicit midpoint
    vec3 a0 = acceleration(p, v, inv_tau_p);
    vec3 pm = p + (0.5 * h) * v;
    vec3 vm = v + (0.5 * h) * a0;
    p += h * vm;
    v += h * acceleration(pm, vm, inv_tau_p);
#elif INTEGRATOR == INTEGRATOR_RK4
    vec3 k1p = v;
    vec3 k1v = acceleration(p, v, inv_tau_p);
    vec3 k2p = v + (0.5 * h) * k1v;
    vec3 k2v = acceleration(p + (0.5 * h) * k1p, k2p, inv_tau_p);
    vec3 k3p = v + (0.5 * h) * k2v;
    vec3 k3v = acceleration(p + (0.5 * h) * k2p, k3p, inv_tau_p);
    vec3 k4p = v + h * k3v;
    vec3 k4v = acceleration(p + h * k3p, k4p, inv_tau_p);
    p += (h / 6.0) * (k1p + 2.0 * k2p + 2.0 * k3p + k4p);
    v += (h / 6.0) * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
#elif INTEGRATOR == INTEGRATOR_EXPONENTIAL
    // Exact solution of dv/dt = f - lambda v with the flow held at its value at p:
    // f = u(p)/tau + g, lambda = 1/tau + k. Stable for any step (stiff fine dust).
    vec3 f;
    float lambda;
    linear_parts(p, inv_tau_p, f, lambda);
    float e, phi1, phi2;
    exponential_weights(lambda * h, e, phi1, phi2);
    p += (h * phi1) * v + (h * h * phi2) * f;
    v = e * v + (h * phi1) * f;
#else
#error unknown INTEGRATOR
#endif
}

#if COLLISION != COLLISION_NONE
uniform float friction;  // nu: share of tangential speed lost at a bounce
uniform float resilience;  // epsilon: share of normal speed kept at a bounce
uniform float friction_min_speed;
#if COLLISION == COLLISION_PLANE
uniform float ground_z;

void ground_at(vec2 xy, out float height, out vec3 normal) {
    height = ground_z;
    normal = vec3(0.0, 0.0, 1.0);
}
#else
#include "heightfield.glsl"
#endif

// Kolb et al.: v' = (1 - nu) v_t - epsilon v_n when heading into the ground, no friction
// below a small speed; a particle caught below the surface is pushed back onto it.
void collide(inout vec3 p, inout vec3 v) {
    float height;
    vec3 n;
    ground_at(p.xy, height, n);
    if (p.z >= height) {
        return;
    }
    p.z = height;
    float vn = dot(v, n);
    if (vn < 0.0) {
        vec3 v_normal = vn * n;
        vec3 v_tangent = v - v_normal;
        float keep = length(v) < friction_min_speed ? 1.0 : 1.0 - friction;
        v = keep * v_tangent - resilience * v_normal;
    }
}
#endif

// Beyond this a state is lost to overflow; such a particle is dropped, never stored.
const float RUNAWAY = 1e15;

// Compared as bits: the magnitude bits of non-negative floats order as their values, and
// NaN and Inf lie above every finite one. A driver may fold isnan() to false (GLSL does
// not require NaNs) or treat float compares with NaN loosely; integer compares are exact.
bool finite(vec3 x) {
    uvec3 magnitude = floatBitsToUint(x) & uvec3(0x7FFFFFFFu);
    return all(lessThan(magnitude, uvec3(floatBitsToUint(RUNAWAY))));
}

// One step of one particle's motion. Returns false when the step ran away (an unstable
// integrator, an absurd field): the particle pass drops it, so NaN or Inf never reach the
// GPU state (a status, not a crash).
bool advance(inout Particle q, float h) {
    integrate(q.pos, q.vel, inverse_relaxation_time(q.class_id), h);
#if COLLISION != COLLISION_NONE
    collide(q.pos, q.vel);
#endif
    return finite(q.pos) && finite(q.vel);
}

// One frame of one particle, the arithmetic both engine paths' particle passes share
// (GS/TF update.glsl, compute update_blocks.glsl): it ages by h and moves.
// Returns whether it lives on: not expired and not run away.
bool step_particle(inout Particle q, float h) {
    q.age += double(h);
    bool sane = advance(q, h);
    return q.age < double(q.lifetime) && sane;
}
