#version 450 core
// Shadow maps (runtime/lights_pass.cpp): depth alone. The rasteriser keeps
// each texel's nearest occluder: a cube face's reversed depth, near / the
// distance along the face's axis, or a directional light's depth along the
// light from the map's plane over the map's span.
void main() {}
