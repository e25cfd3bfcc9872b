#include "../outside.glsl"
