// The arithmetic of everything that enters the hashed particle state, in one of two modes
// chosen by ARITHMETIC (unset: native):
//   ARITHMETIC_NATIVE: the plain operators and GLSL built-ins, as fast as the GPU goes. The
//     GLSL spec leaves division (2.5 ULP), sqrt, exp, log, pow, sin and cos to the driver
//     and lets the compiler fuse a*b+c, so GPUs of different vendors part after a while.
//   ARITHMETIC_PORTABLE: the same bits on every GPU. Only +, - and * of the hardware are
//     used, each correctly rounded (GLSL 4.30, 4.7.1) and kept unfused by `precise`;
//     division and square root are Newton-Raphson estimates made exact by integer
//     remainders on the 24-bit significands (uint arithmetic is exact), so correctly
//     rounded; exp, log, sin and cos are Cody-Waite range reductions and Horner
//     polynomials (Moshier's Cephes expf, logf, sinf, cosf) of those +, -, *.
//     Subnormals are handled in code, never by the hardware (llvmpipe flushes them,
//     NVIDIA flushes in GL, others keep them):
//     - an operand whose exponent field is 0 reads as a zero of its sign (DAZ);
//     - a result is its exact value rounded to nearest even to 24 bits with an unbounded
//       exponent, then a zero of its sign if below 2^-126 in magnitude, inf if 2^128 or
//       more (FTZ by one definition: tininess after rounding);
//     - a NaN result is the quiet NaN 0x7fc00000, whatever the hardware's NaN.
// cavesim/core/portable/arithmetic.py is the float32 numpy twin: the same operation
// sequences, bit for bit. README.md "Portable arithmetic" states accuracy and cost.
#pragma once

#define ARITHMETIC_NATIVE 0
#define ARITHMETIC_PORTABLE 1

#if !defined ARITHMETIC
#define ARITHMETIC_MODE ARITHMETIC_NATIVE
#else
#define ARITHMETIC_MODE ARITHMETIC
#endif
#if ARITHMETIC_MODE != ARITHMETIC_NATIVE && ARITHMETIC_MODE != ARITHMETIC_PORTABLE
#error ARITHMETIC must be ARITHMETIC_NATIVE (0) or ARITHMETIC_PORTABLE (1)
#endif

#if ARITHMETIC_MODE == ARITHMETIC_PORTABLE
#include "portable_operations.glsl"
#include "portable_functions.glsl"

#else  // ARITHMETIC_NATIVE: the operators and built-ins themselves

float f_ftz(float x) { return x; }
vec2 f_ftz(vec2 x) { return x; }
vec3 f_ftz(vec3 x) { return x; }
float f_add(float a, float b) { return a + b; }
vec2 f_add(vec2 a, vec2 b) { return a + b; }
vec3 f_add(vec3 a, vec3 b) { return a + b; }
float f_sub(float a, float b) { return a - b; }
vec2 f_sub(vec2 a, vec2 b) { return a - b; }
vec3 f_sub(vec3 a, vec3 b) { return a - b; }
float f_mul(float a, float b) { return a * b; }
vec2 f_mul(vec2 a, vec2 b) { return a * b; }
vec3 f_mul(vec3 a, vec3 b) { return a * b; }
vec2 f_mul(float a, vec2 b) { return a * b; }
vec3 f_mul(float a, vec3 b) { return a * b; }
vec2 f_mul(vec2 a, float b) { return a * b; }
vec3 f_mul(vec3 a, float b) { return a * b; }
float f_div(float a, float b) { return a / b; }
vec2 f_div(vec2 a, vec2 b) { return a / b; }
vec3 f_div(vec3 a, vec3 b) { return a / b; }
vec2 f_div(vec2 a, float b) { return a / b; }
vec3 f_div(vec3 a, float b) { return a / b; }
float f_sqrt(float x) { return sqrt(x); }
float f_exp(float x) { return exp(x); }
float f_log(float x) { return log(x); }
float f_pow(float x, float y) { return pow(x, y); }
float f_sin(float x) { return sin(x); }
float f_cos(float x) { return cos(x); }
float f_dot(vec3 a, vec3 b) { return dot(a, b); }
float f_dot(vec2 a, vec2 b) { return dot(a, b); }
float f_length(vec3 x) { return length(x); }
float f_length(vec2 x) { return length(x); }
vec3 f_normalize(vec3 x) { return normalize(x); }
float f_mix(float a, float b, float t) { return mix(a, b, t); }
vec2 f_mix(vec2 a, vec2 b, vec2 t) { return mix(a, b, t); }
vec3 f_mix(vec3 a, vec3 b, vec3 t) { return mix(a, b, t); }
vec2 f_mix(vec2 a, vec2 b, float t) { return mix(a, b, t); }
vec3 f_mix(vec3 a, vec3 b, float t) { return mix(a, b, t); }

#endif
