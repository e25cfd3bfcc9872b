// a file whose last line includes another
#include "lib/inner.glsl"
