// a typo in the include below
float f();
#include "lib/no_such_file.glsl"
