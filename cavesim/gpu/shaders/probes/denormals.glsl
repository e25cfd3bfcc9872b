// How a stage treats denormal floats: each value, near or below the smallest normal float,
// times 0.75 plus a product that is itself denormal. A stage that flushes denormals (to
// zero, in its inputs or its results) gives other bits than one that keeps them. The same
// arithmetic runs as a vertex shader (transform feedback) and as a compute shader.

float probe(uint bits) {
    float x = uintBitsToFloat(bits);
    return x * 0.75 + x * 1e-3;
}

#if defined VERTEX_SHADER
in uint in_bits;
flat out uint flushed;

void main() {
    flushed = floatBitsToUint(probe(in_bits));
}
#endif

#if defined COMPUTE_SHADER
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Inputs {
    uint inputs[];
};
layout(std430, binding = 1) writeonly buffer Outputs {
    uint outputs[];
};
uniform uint value_count;

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n < value_count) {
        outputs[n] = floatBitsToUint(probe(inputs[n]));
    }
}
#endif
