// Passive tracers (HAS_TRACERS): the classes that tracer_classes marks move with the flow,
// stepped by TRACER_METHOD; RK45 in substeps held to tracer_tolerance. Twins:
// cavesim/core/twin/tracers.py and cavesim/core/portable/tracers.py.
#pragma once
#include "arithmetic.glsl"
#include "counters.glsl"
#include "integrators.glsl"
#include "position.glsl"

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
    // the frame's tracers, their substeps taken and retaken, and the most one tracer took
#if COUNT_TRACERS_STEPPED
    count_add(TRACERS_STEPPED_AT, 1u);
#endif
#if COUNT_SUBSTEPS_TAKEN
    count_add(SUBSTEPS_TAKEN_AT, taken);
#endif
#if COUNT_SUBSTEPS_RETAKEN
    count_add(SUBSTEPS_RETAKEN_AT, retaken);
#endif
#if COUNT_MOST_SUBSTEPS
    count_max(MOST_SUBSTEPS_AT, taken);
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
