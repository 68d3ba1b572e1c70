// Embree scenes of sylva's triangle meshes, as the colour renderer (colour_render.h) and the
// laser scanner (pipeline/scan/scan_scene.h) build them: the device, scenes with robust
// traversal, and triangle geometries copied from a mesh's arrays. Errors are exceptions
// ("Embree: <what> failed …"), never Embree's own messages.
#pragma once

#include <embree3/rtcore.h>

#include <cstddef>
#include <cstdint>

namespace sylva {

// Throws std::runtime_error("Embree: <what> failed (error N)") if `device` holds an error.
void checkEmbree(RTCDevice device, const char* what);

// A new device (Embree's default configuration); throws if there is none.
RTCDevice newEmbreeDevice();

// A new scene of `device` with robust traversal (a ray through the shared edge of two
// triangles is never lost: no ray slips into a trunk, no mask pixel goes unhit) and medium
// build quality.
RTCScene newRobustScene(RTCDevice device);

// Copies `triangles` triangles (three indices each into `positions`, xyz floats of `vertices`
// vertices) into a new triangle geometry of `scene`, committed and attached; returns its
// geometry id. No triangles: one degenerate triangle at the origin, which no ray hits, so that
// the ids of the geometries after it stay where the caller expects them.
unsigned attachTriangles(RTCDevice device, RTCScene scene, const float* positions, size_t vertices,
                         const uint32_t* indices, size_t triangles);

}  // namespace sylva
