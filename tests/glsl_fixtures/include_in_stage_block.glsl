#if defined VERTEX_SHADER
#include "lib/common.glsl"
#else
float other;
#endif
void main() {}
