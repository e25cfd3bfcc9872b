#include "lib/outer.glsl"
void main() {}
