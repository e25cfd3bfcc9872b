float speed() { return SPEED; }
#if defined FRAGMENT_SHADER
out vec4 color;
#endif
