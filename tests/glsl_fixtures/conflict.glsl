// local override the caller cannot see
#define SPEED 2.0
