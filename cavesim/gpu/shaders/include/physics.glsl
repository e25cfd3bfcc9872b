// The forces on a particle and the integrators that advance it by one step. Each scene
// compiles in only the forces it has (HAS_GRAVITY, HAS_DRAG, HAS_DAMPING, with drag
// HAS_SCHILLER_NAUMANN and HAS_DISPERSION), one INTEGRATOR and one COLLISION kind;
// cavesim/core/twin/ holds the float64 twin of every line. With HAS_TRACERS the classes
// that tracer_classes marks are passive tracers, stepped by TRACER_METHOD instead (trace).
// Every float operation goes through arithmetic.glsl (f_add, f_mul, ...): plain operators
// for ARITHMETIC_NATIVE, the same bits on every GPU for ARITHMETIC_PORTABLE, mirrored
// operation by operation in float32 by cavesim/core/portable/.
#pragma once
#include "arithmetic.glsl"
#include "position.glsl"

#define INTEGRATOR_EXPLICIT_EULER 0
#define INTEGRATOR_SEMI_IMPLICIT_EULER 1
#define INTEGRATOR_TRAPEZOID 2
#define INTEGRATOR_VERLET 3
#define INTEGRATOR_RK2 4
#define INTEGRATOR_RK4 5
#define INTEGRATOR_EXPONENTIAL 6
#define INTEGRATOR_ETD2RK 7
#define TRACER_EULER 0
#define TRACER_MIDPOINT 1
#define TRACER_HEUN 2
#define TRACER_RK4 3
#define TRACER_RK45 4
#define COLLISION_NONE 0
#define COLLISION_PLANE 1
#define COLLISION_HEIGHTFIELD 2
#define OUT_OF_DOMAIN_CLAMP 0
#define OUT_OF_DOMAIN_ZERO 1
#define SAMPLING_MANUAL 0
#define SAMPLING_HARDWARE 1
#define INTERPOLATION_TRILINEAR 0
#define INTERPOLATION_CATMULL_ROM 1
#define INTERPOLATION_BSPLINE 2
// where in its step an integrator takes the flow (a time-series field moves between them)
#define STAGE_START 0
#define STAGE_MIDDLE 1
#define STAGE_END 2

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

// Both act through drag; dispersion measures heights from the ground (the scene loader's
// rules; programs.physics_defines and physics_variants keep to them)
#if (HAS_SCHILLER_NAUMANN || HAS_DISPERSION) && !HAS_DRAG
#error HAS_SCHILLER_NAUMANN and HAS_DISPERSION need HAS_DRAG
#endif
#if COUNT_DOMAIN_EXITS && (!HAS_DRAG || FIELD_IS_ROTOR)
#error COUNT_DOMAIN_EXITS needs a gridded field
#endif
#if HAS_DISPERSION && COLLISION == COLLISION_NONE
#error HAS_DISPERSION needs a COLLISION ground
#endif
// A tracer moves with the flow that drag brings in; dispersion's random walk is drag's
#if HAS_TRACERS && (!HAS_DRAG || HAS_DISPERSION)
#error HAS_TRACERS needs HAS_DRAG and no HAS_DISPERSION
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
    return remainder;
#else
    return forcing(vec3(0.0), held);
#endif
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
    lambda = drag;
#if HAS_DAMPING
    lambda = f_add(lambda, damping);
#endif
    return drag;
}

#if INTEGRATOR == INTEGRATOR_EXPONENTIAL || INTEGRATOR == INTEGRATOR_ETD2RK
// 1/k! of the series below, as exact bits: how a literal such as 1.0 / 6.0 is rounded is
// up to the compiler (macros: glslang refuses uintBitsToFloat in a const initializer;
// cavesim/core/portable/constants.py holds the same bits)
#define INV_FACTORIAL_3 uintBitsToFloat(0x3E2AAAABu)
#define INV_FACTORIAL_4 uintBitsToFloat(0x3D2AAAABu)
#define INV_FACTORIAL_5 uintBitsToFloat(0x3C088889u)
#define INV_FACTORIAL_6 uintBitsToFloat(0x3AB60B61u)
#define INV_FACTORIAL_7 uintBitsToFloat(0x39500D01u)
#define INV_FACTORIAL_8 uintBitsToFloat(0x37D00D01u)

// phi1(x) = (1 - e^-x) / x and phi2(x) = (x - 1 + e^-x) / x^2, by series where the closed
// forms cancel catastrophically in float32.
void exponential_weights(float x, out float e, out float phi1, out float phi2) {
    e = f_exp(-x);
    if (x < 0.5) {
        float tail1 = f_sub(INV_FACTORIAL_6, f_mul(x, INV_FACTORIAL_7));
        tail1 = f_sub(INV_FACTORIAL_5, f_mul(x, tail1));
        tail1 = f_sub(INV_FACTORIAL_4, f_mul(x, tail1));
        tail1 = f_sub(INV_FACTORIAL_3, f_mul(x, tail1));
        tail1 = f_sub(0.5, f_mul(x, tail1));
        phi1 = f_sub(1.0, f_mul(x, tail1));
        float tail2 = f_sub(INV_FACTORIAL_7, f_mul(x, INV_FACTORIAL_8));
        tail2 = f_sub(INV_FACTORIAL_6, f_mul(x, tail2));
        tail2 = f_sub(INV_FACTORIAL_5, f_mul(x, tail2));
        tail2 = f_sub(INV_FACTORIAL_4, f_mul(x, tail2));
        tail2 = f_sub(INV_FACTORIAL_3, f_mul(x, tail2));
        phi2 = f_sub(0.5, f_mul(x, tail2));
    } else {
        phi1 = f_div(f_sub(1.0, e), x);
        phi2 = f_div(f_add(f_sub(x, 1.0), e), f_mul(x, x));
    }
}
#endif

#if INTEGRATOR == INTEGRATOR_ETD2RK
#define INV_FACTORIAL_9 uintBitsToFloat(0x3638EF1Du)
#define INV_FACTORIAL_10 uintBitsToFloat(0x3493F27Eu)
#define INV_FACTORIAL_11 uintBitsToFloat(0x32D7322Bu)

// phi3(x) = (x^2/2 - x + 1 - e^-x) / x^3 = (1/2 - phi2) / x; below x = 1, where that
// cancels, its series to x^8/11! (the first term left out is below 2e-8 of phi3).
float phi3_weight(float x, float phi2) {
    if (x < 1.0) {
        float tail = f_sub(INV_FACTORIAL_10, f_mul(x, INV_FACTORIAL_11));
        tail = f_sub(INV_FACTORIAL_9, f_mul(x, tail));
        tail = f_sub(INV_FACTORIAL_8, f_mul(x, tail));
        tail = f_sub(INV_FACTORIAL_7, f_mul(x, tail));
        tail = f_sub(INV_FACTORIAL_6, f_mul(x, tail));
        tail = f_sub(INV_FACTORIAL_5, f_mul(x, tail));
        tail = f_sub(INV_FACTORIAL_4, f_mul(x, tail));
        return f_sub(INV_FACTORIAL_3, f_mul(x, tail));
    }
    return f_div(f_sub(0.5, phi2), x);
}
#endif

// k1 + 2 k2 + 2 k3 + k4: the classic Runge-Kutta method's weighted sum of its stages,
// times h/6 its increment (of a particle's position and velocity, or a tracer's position)
vec3 rk4_sum(vec3 k1, vec3 k2, vec3 k3, vec3 k4) {
    return f_add(f_add(f_add(k1, f_mul(2.0, k2)), f_mul(2.0, k3)), k4);
}

// Every method moves the position once a step, by one whole increment: p = move(p, h * (...))
// adds it to the position's 32 bits exactly (position.glsl). The implicit ones step the
// velocity by an increment of the acceleration r = f - lambda v rather than by weights that
// decay it: a weight near 1 (e^-x, 1 / (1 + x)) rounded to float32 is the same relative error
// every step, a drift that grows as dt shrinks. So the state's storage is all float32 adds
// (README: the float32 floor).
void integrate(inout vec3 p, inout vec3 v, float inv_tau_p, float h) {
#if INTEGRATOR == INTEGRATOR_EXPLICIT_EULER
    vec3 a = acceleration(p, v, inv_tau_p, STAGE_START);
    p = move(p, f_mul(h, v));
    v = f_add(v, f_mul(h, a));
#elif INTEGRATOR == INTEGRATOR_SEMI_IMPLICIT_EULER
    // linearly implicit in the stiff drag and damping, explicit in the rest; the new
    // velocity moves the position. Stable for any tau: v' = v + h (f - lambda v) / (1 + h lambda)
    vec3 f;
    float lambda;
    linear_parts(p, v, inv_tau_p, f, lambda);
    float weight = f_div(h, f_add(1.0, f_mul(h, lambda)));
    v = f_add(v, f_mul(weight, f_sub(f, f_mul(lambda, v))));
    p = move(p, f_mul(h, v));
#elif INTEGRATOR == INTEGRATOR_TRAPEZOID
    // UberFlow eq. (1)-(2): Euler velocity, position from the mean of old and new velocity
    float half_h = f_mul(0.5, h);
    vec3 v1 = f_add(v, f_mul(h, acceleration(p, v, inv_tau_p, STAGE_START)));
    p = move(p, f_mul(half_h, f_add(v, v1)));
    v = v1;
#elif INTEGRATOR == INTEGRATOR_VERLET
    // velocity Verlet; the drag's velocity dependence is met with an Euler-predicted velocity
    float half_h = f_mul(0.5, h);
    vec3 a0 = acceleration(p, v, inv_tau_p, STAGE_START);
    p = move(p, f_mul(h, f_add(v, f_mul(half_h, a0))));
    vec3 a1 = acceleration(p, f_add(v, f_mul(h, a0)), inv_tau_p, STAGE_END);
    v = f_add(v, f_mul(half_h, f_add(a0, a1)));
#elif INTEGRATOR == INTEGRATOR_RK2
    // explicit midpoint
    float half_h = f_mul(0.5, h);
    vec3 a0 = acceleration(p, v, inv_tau_p, STAGE_START);
    vec3 pm = f_add(p, f_mul(half_h, v));
    vec3 vm = f_add(v, f_mul(half_h, a0));
    p = move(p, f_mul(h, vm));
    v = f_add(v, f_mul(h, acceleration(pm, vm, inv_tau_p, STAGE_MIDDLE)));
#elif INTEGRATOR == INTEGRATOR_RK4
    float half_h = f_mul(0.5, h);
    vec3 k1p = v;
    vec3 k1v = acceleration(p, v, inv_tau_p, STAGE_START);
    vec3 k2p = f_add(v, f_mul(half_h, k1v));
    vec3 k2v = acceleration(f_add(p, f_mul(half_h, k1p)), k2p, inv_tau_p, STAGE_MIDDLE);
    vec3 k3p = f_add(v, f_mul(half_h, k2v));
    vec3 k3v = acceleration(f_add(p, f_mul(half_h, k2p)), k3p, inv_tau_p, STAGE_MIDDLE);
    vec3 k4p = f_add(v, f_mul(h, k3v));
    vec3 k4v = acceleration(f_add(p, f_mul(h, k3p)), k4p, inv_tau_p, STAGE_END);
    float sixth_h = f_div(h, 6.0);
    p = move(p, f_mul(sixth_h, rk4_sum(k1p, k2p, k3p, k4p)));
    v = f_add(v, f_mul(sixth_h, rk4_sum(k1v, k2v, k3v, k4v)));
#elif INTEGRATOR == INTEGRATOR_EXPONENTIAL
    // Exponential Euler: exact solution of dv/dt = f - lambda v with the flow and the drag
    // rate held at their values at (p, v) (linear_parts). Stable for any step (stiff fine
    // dust). Increment form: r = f - lambda v, p += h (v + h phi2 r), v += h phi1 r.
    vec3 f;
    float lambda;
    linear_parts(p, v, inv_tau_p, f, lambda);
    float e, phi1, phi2;
    exponential_weights(f_mul(lambda, h), e, phi1, phi2);
    vec3 r = f_sub(f, f_mul(lambda, v));
    p = move(p, f_mul(h, f_add(v, f_mul(f_mul(h, phi2), r))));
    v = f_add(v, f_mul(f_mul(h, phi1), r));
#elif INTEGRATOR == INTEGRATOR_ETD2RK
    // ETD2RK (Cox & Matthews 2002), order 2 for every drag law and stable for any step:
    // the exponential step predicts (pa, va), the remainder N of the linear part is taken
    // linear in time from N(p, v) = f to N(pa, va), and the linear part is solved exactly
    // against it (twin: etd2rk in cavesim/core/twin/integrators.py, which derives it):
    //   p' = p + h (v + h phi2 r + h phi3 d),  v' = v + h (phi1 r + phi2 d)
    vec3 f;
    float lambda;
    float drag = linear_parts(p, v, inv_tau_p, f, lambda);
    float x = f_mul(lambda, h);
    float e, phi1, phi2;
    exponential_weights(x, e, phi1, phi2);
    float phi3 = phi3_weight(x, phi2);
    vec3 r = f_sub(f, f_mul(lambda, v));
    vec3 w = f_add(v, f_mul(f_mul(h, phi2), r));
    vec3 pa = f_add(p, f_mul(h, w));
    vec3 va = f_add(v, f_mul(f_mul(h, phi1), r));
    vec3 d = f_sub(remainder_at(pa, va, drag, inv_tau_p), f);
    p = move(p, f_mul(h, f_add(w, f_mul(f_mul(h, phi3), d))));
    v = f_add(v, f_mul(h, f_add(f_mul(phi1, r), f_mul(phi2, d))));
#else
#error unknown INTEGRATOR
#endif
}

#if HAS_TRACERS
uniform uvec2 tracer_classes;  // bit c: class c is a passive tracer (64 classes at most)

bool is_tracer(uint class_id) {
    uint c = min(class_id, uint(CLASS_COUNT - 1));
    return ((tracer_classes[c / 32u] >> (c % 32u)) & 1u) != 0u;
}

#if TRACER_METHOD == TRACER_RK45
// Dormand-Prince 5(4) on binary substeps of the step h (cavesim/core/substeps.py): a substep
// of h / 2^level whose error estimate exceeds tracer_tolerance is taken again at half the
// size; one RK45_GROWTH_MARGIN times under it lets the next double where that stays aligned;
// level RK45_MAX_LEVEL is always taken. Starts and sizes are whole RK45_UNITS-ths of h.
#define RK45_MAX_LEVEL 6
#define RK45_UNITS 64u
#define RK45_UNIT 0.015625  // 1 / RK45_UNITS, exact
#define RK45_MAX_ATTEMPTS 134  // 2 RK45_UNITS + RK45_MAX_LEVEL: enough to reach h
#define RK45_GROWTH_MARGIN 32.0
#define RK45_STAGES 7
#define RK45_ERROR_WEIGHTS 21  // where b5 - b4 start in rk45_tableau
uniform vec4 rk45_tableau[7];  // A's rows for stages 2 to 7 (21), then b5 - b4 (7): float32
uniform vec4 rk45_nodes;  // c of stages 2 to 5; stage 1 takes the flow at 0, 6 and 7 at 1
uniform float tracer_tolerance;  // m: the largest error estimate a substep may have

float rk45_coefficient(int i) {
    return rk45_tableau[i / 4][i % 4];
}

float rk45_node(int stage) {
    return stage == 0 ? 0.0 : stage < 5 ? rk45_nodes[stage - 1] : 1.0;
}

#if COUNT_TRACER_SUBSTEPS && !defined GEOMETRY_SHADER
// the frame's tracers, their substeps taken and retaken, and the most one tracer took
// (cavesim/gpu/engine/frame_counts.py clears it before the frame and reads it after)
layout(std430, binding = 7) buffer TracerSubsteps {
    uint tracer_substeps[4];
};
#define COUNTS_SUBSTEPS_HERE 1
#else
#define COUNTS_SUBSTEPS_HERE 0
#endif

// One step h of an adaptive tracer from p, where the flow is k1: moves p and returns the
// flow at the step's end, which its last substep took
vec3 trace_in_substeps(inout vec3 p, vec3 k1, float h) {
    vec3 k[RK45_STAGES];
    k[0] = k1;
    uint done = 0u;  // RK45_UNITS-ths of h stepped
    int level = 0;
    uint taken = 0u;
    uint retaken = 0u;
    for (int attempt = 0; attempt < RK45_MAX_ATTEMPTS && done < RK45_UNITS; ++attempt) {
        uint units = RK45_UNITS >> uint(level);
        float share = f_mul(float(units), RK45_UNIT);
        float start = f_mul(float(done), RK45_UNIT);
        float sub_h = f_mul(share, h);
        vec3 increment = vec3(0.0);
        for (int s = 1; s < RK45_STAGES; ++s) {  // one call site of the flow
            int row = s * (s - 1) / 2;
            vec3 sum = vec3(0.0);
            for (int j = 0; j < s; ++j) {
                sum = f_add(sum, f_mul(rk45_coefficient(row + j), k[j]));
            }
            increment = f_mul(sub_h, sum);
            k[s] = flow_in_step(f_add(p, increment),
                                f_add(start, f_mul(rk45_node(s), share)));
        }
        vec3 estimate = vec3(0.0);
        for (int j = 0; j < RK45_STAGES; ++j) {
            estimate = f_add(estimate, f_mul(rk45_coefficient(RK45_ERROR_WEIGHTS + j), k[j]));
        }
        vec3 e = abs(f_mul(sub_h, estimate));
        float error = max(e.x, max(e.y, e.z));
        if (error <= tracer_tolerance || level == RK45_MAX_LEVEL) {
            p = move(p, increment);  // the last stage's point: the fifth-order solution
            k[0] = k[RK45_STAGES - 1];
            done += units;
            taken += 1u;
            if (level > 0 && f_mul(RK45_GROWTH_MARGIN, error) <= tracer_tolerance
                    && done % (2u * units) == 0u) {
                level -= 1;
            }
        } else {
            level += 1;
            retaken += 1u;
        }
    }
#if COUNTS_SUBSTEPS_HERE
    atomicAdd(tracer_substeps[0], 1u);
    atomicAdd(tracer_substeps[1], taken);
    atomicAdd(tracer_substeps[2], retaken);
    atomicMax(tracer_substeps[3], taken);
#endif
    return k[0];
}
#endif

// A passive tracer, dx/dt = u(x, t), one step of TRACER_METHOD (the integrator's form
// without inertia: the Integrator table's tracer_method, or the scene's own). Its velocity
// is the flow at the new position, for drawing; nothing steps it (twin:
// cavesim/core/twin/tracers.py).
void trace(inout vec3 p, out vec3 v, float h) {
    vec3 k1 = flow_at(p, STAGE_START);
#if TRACER_METHOD == TRACER_EULER
    p = move(p, f_mul(h, k1));
#elif TRACER_METHOD == TRACER_MIDPOINT
    p = move(p, f_mul(h, flow_at(f_add(p, f_mul(f_mul(0.5, h), k1)), STAGE_MIDDLE)));
#elif TRACER_METHOD == TRACER_HEUN
    vec3 k2 = flow_at(f_add(p, f_mul(h, k1)), STAGE_END);
    p = move(p, f_mul(f_mul(0.5, h), f_add(k1, k2)));
#elif TRACER_METHOD == TRACER_RK4
    float half_h = f_mul(0.5, h);
    vec3 k2 = flow_at(f_add(p, f_mul(half_h, k1)), STAGE_MIDDLE);
    vec3 k3 = flow_at(f_add(p, f_mul(half_h, k2)), STAGE_MIDDLE);
    vec3 k4 = flow_at(f_add(p, f_mul(h, k3)), STAGE_END);
    p = move(p, f_mul(f_div(h, 6.0), rk4_sum(k1, k2, k3, k4)));
#elif TRACER_METHOD == TRACER_RK45
    v = trace_in_substeps(p, k1, h);
#else
#error unknown TRACER_METHOD
#endif
#if TRACER_METHOD != TRACER_RK45  // RK45's last substep took the flow at the end
    v = flow_at(p, STAGE_END);
#endif
}
#endif

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
    step_position_low.z = 0.0;
    float vn = f_dot(v, n);
    if (vn < 0.0) {
        vec3 v_normal = f_mul(vn, n);
        vec3 v_tangent = f_sub(v, v_normal);
        float keep = f_length(v) < friction_min_speed ? 1.0 : f_sub(1.0, friction);
        v = f_sub(f_mul(keep, v_tangent), f_mul(resilience, v_normal));
    }
}
#endif

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

// The stage that steps the particles counts (a GS/TF program's geometry stage only passes
// them on, and asks for no storage)
#if COUNT_DOMAIN_EXITS && !defined GEOMETRY_SHADER
#define COUNTS_EXITS_HERE 1
#else
#define COUNTS_EXITS_HERE 0
#endif

#if COUNTS_EXITS_HERE
// Per class, the particles that left the field's box this frame (cavesim/gpu/engine/
// domain_exits.py clears it before the frame and reads it after)
layout(std430, binding = 6) buffer DomainExits {
    uint domain_exits[];
};
#endif

// One frame of the particle at `index` in the stream, the arithmetic both engine paths'
// particle passes share (GS/TF update.glsl, compute update_blocks.glsl): it ages by h
// and moves; with COUNT_DOMAIN_EXITS, a sane step from inside the field's box to outside
// it counts for the particle's class.
// Returns whether it lives on: not expired and not run away. The age's float64 add stays
// outside arithmetic.glsl: portable only where the GPU rounds doubles as IEEE does.
bool step_particle(inout Particle q, float h, uint index) {
    q.age += double(h);
#if COUNTS_EXITS_HERE
    bool was_inside = !outside_field(field_coordinates(q.pos));
#endif
    bool sane = advance(q, h, index);
#if COUNTS_EXITS_HERE
    if (sane && was_inside && outside_field(field_coordinates(q.pos))) {
        atomicAdd(domain_exits[min(q.class_id, uint(CLASS_COUNT - 1))], 1u);
    }
#endif
    return q.age < double(q.lifetime) && sane;
}
