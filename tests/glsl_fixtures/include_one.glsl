// uses the common helpers
#include "lib/common.glsl"
void main() {}
