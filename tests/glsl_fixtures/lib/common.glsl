const float TAU = 6.2831853;
float twice(float x) { return 2.0 * x; }
