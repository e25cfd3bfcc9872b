// How exactly this GPU's texture unit weighs two texels: a 2x1x1 float texture holding 0
// and 1, filtered linearly at `sample_count` evenly spaced points between the two texel
// centres, addressed as flow_at addresses the flow field (shaders/include/field.glsl).
// Exact weights give back each point's fraction; 8-bit weights miss by up to 1/512.

#if defined COMPUTE_SHADER
layout(local_size_x = 64) in;
layout(std430, binding = 0) writeonly buffer Filtered {
    float filtered[];
};
uniform sampler3D ramp;
uniform uint sample_count;

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n >= sample_count) {
        return;
    }
    float f = float(n) / float(sample_count);
    filtered[n] = texture(ramp, (vec3(f, 0.0, 0.0) + 0.5) / vec3(2.0, 1.0, 1.0)).x;
}
#endif
