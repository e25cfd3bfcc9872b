#include "lib/once_lib.glsl"
#include "lib/once_lib.glsl"
#include "lib/inner.glsl"
#include "lib/inner.glsl"
