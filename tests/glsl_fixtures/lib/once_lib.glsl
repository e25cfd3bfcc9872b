#pragma once
struct Particle { vec3 p; };
