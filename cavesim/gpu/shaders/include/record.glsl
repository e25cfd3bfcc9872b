// One particle as it lives in the particle stream: 10 words, 40 bytes, in this order:
// pos.xyz, vel.xyz (float32), age (float64 as two words), lifetime (float32), and one word
// of four bytes: class, then the position's low part per axis (signed; position.glsl).
// The stream moves through transform feedback as three integer varyings (uvec4, uvec4,
// uvec2): fewer, wider varyings are ~13% faster on llvmpipe, and integer bits pass untouched.
#pragma once
#include "position.glsl"

struct Particle {
    vec3 pos;
    vec3 pos_low;  // what the float32 pos leaves out, to 1/256 of its spacing
    vec3 vel;
    double age;  // float64 so a lifetime is exact to the frame over any number of steps
    float lifetime;
    uint class_id;
};

Particle unpack_particle(uvec4 a, uvec4 b, uvec2 c) {
    Particle q;
    q.pos = uintBitsToFloat(a.xyz);
    q.vel = uintBitsToFloat(uvec3(a.w, b.xy));
    q.age = packDouble2x32(b.zw);
    q.lifetime = uintBitsToFloat(c.x);
    q.class_id = c.y & 0xFFu;
    int word = int(c.y);
    ivec3 code = ivec3(bitfieldExtract(word, 8, 8), bitfieldExtract(word, 16, 8),
                       bitfieldExtract(word, 24, 8));
    q.pos_low = low_part(q.pos, code);
    return q;
}

void pack_particle(Particle q, out uvec4 a, out uvec4 b, out uvec2 c) {
    a = uvec4(floatBitsToUint(q.pos), floatBitsToUint(q.vel.x));
    b = uvec4(floatBitsToUint(q.vel.yz), unpackDouble2x32(q.age));
    uvec3 code = uvec3(low_code(q.pos, q.pos_low)) & uvec3(0xFFu);
    c = uvec2(floatBitsToUint(q.lifetime),
              q.class_id | (code.x << 8) | (code.y << 16) | (code.z << 24));
}
