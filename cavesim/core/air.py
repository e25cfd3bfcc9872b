"""The air the particles move in: its properties at the conditions a scene assumes by
default, and the constant of its turbulence near the ground."""

AIR_VISCOSITY = 1.81e-5  # Pa·s, dry air at 15 °C
AIR_DENSITY = 1.225  # kg/m³, dry air at 15 °C and sea level (ISA)
KARMAN = 0.4  # von Kármán's constant of the logarithmic wall layer
