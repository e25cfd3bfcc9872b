// The integrators that advance a particle by one step, one INTEGRATOR compiled in. Twins:
// cavesim/core/twin/integrators.py and cavesim/core/portable/integrators.py.
#pragma once
#include "arithmetic.glsl"
#include "forces.glsl"
#include "position.glsl"

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
