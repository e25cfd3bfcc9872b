// b pulls a back in
#include "cycle_a.glsl"
