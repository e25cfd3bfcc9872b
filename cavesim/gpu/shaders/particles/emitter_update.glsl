// Emitter pass, part 1 (transform feedback, one record in, one out): each emitter adds
// rate·dt to its float64 accumulator and takes the whole part as this frame's count, so a
// rate of 12.5/s at 60 Hz emits exactly 125 particles in 10 s. Its float64 multiply and
// add stay outside arithmetic.glsl: `precise` keeps them from fusing, and they are portable
// where the GPU rounds doubles as IEEE does.
#include "/include/emitters.glsl"

#if defined VERTEX_SHADER
in uvec4 in_state;
flat out uvec4 out_state;

void main() {
    int e = gl_VertexID;
    precise double accumulated = packDouble2x32(in_state.xy) + frame_rate(e) * double(dt);
    double whole = floor(accumulated);
    uint count = uint(min(whole, double(emitter_max_emit(e))));
    out_state = uvec4(unpackDouble2x32(accumulated - whole), count, in_state.w + in_state.z);
}
#endif
