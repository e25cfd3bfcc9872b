#include "inner.glsl"
#include "/lib/common.glsl"
float outer() { return inner(); }
