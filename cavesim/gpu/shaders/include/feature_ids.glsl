// The ids a scene's feature defines take (INTEGRATOR, TRACER_METHOD, COLLISION, the field's
// FIELD_OUT_OF_DOMAIN, FIELD_SAMPLING and FIELD_INTERPOLATION), and where in its step an
// integrator takes the flow.
#pragma once

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
