#if defined VERTEX_SHADER
void main() { gl_Position = vec4(0.0); }
#endif
#if defined FRAGMENT_SHADER
#include "broken_helper.glsl"
out vec4 color;
void main() { color = vec4(helper()); }
#endif
