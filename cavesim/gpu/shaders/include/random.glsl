// The shared random texture and this frame's map of it: every node holds the same words
// (built from the scene's seed) and gets the same integer map each frame, so every lookup
// reads the same bits everywhere. Twin: cavesim/core/random_texture.py.
#pragma once

uniform usampler2D random_texture;  // RGBA32UI, RANDOM_SIZE square, read with texelFetch only
uniform mat3 random_transform;  // this frame's integer affine map of the texel lattice

// The texel at lattice index k, laid out row by row from `base`, moved by the frame's map;
// the arithmetic is integer and wraps modulo 2^32, so it is exact on every GPU.
// Twin: random_texture.py moved_texel.
uvec4 random_texel(uvec2 base, uint k) {
    const uint mask = uint(RANDOM_SIZE - 1);
    int x = int((base.x + (k & mask)) & mask);
    int y = int((base.y + k / uint(RANDOM_SIZE)) & mask);
    ivec3 col0 = ivec3(random_transform[0]);
    ivec3 col1 = ivec3(random_transform[1]);
    ivec3 col2 = ivec3(random_transform[2]);
    int moved_x = (col0.x * x + col1.x * y + col2.x) & int(mask);
    int moved_y = (col0.y * x + col1.y * y + col2.y) & int(mask);
    return texelFetch(random_texture, ivec2(moved_x, moved_y), 0);
}
