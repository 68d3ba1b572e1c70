#include "pipeline/render/embree_scene.h"

#include <cstring>
#include <stdexcept>
#include <string>

namespace sylva {

void checkEmbree(RTCDevice device, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE) {
        throw std::runtime_error(std::string("Embree: ") + what + " failed (error " +
                                 std::to_string(static_cast<int>(e)) + ")");
    }
}

RTCDevice newEmbreeDevice() {
    RTCDevice device = rtcNewDevice(nullptr);
    if (!device) throw std::runtime_error("Embree: rtcNewDevice failed");
    return device;
}

RTCScene newRobustScene(RTCDevice device) {
    RTCScene s = rtcNewScene(device);
    checkEmbree(device, "rtcNewScene");
    rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_MEDIUM);
    return s;
}

unsigned attachTriangles(RTCDevice device, RTCScene scene, const float* positions, size_t vertices,
                         const uint32_t* indices, size_t triangles) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    checkEmbree(device, "rtcNewGeometry");
    const bool empty = triangles == 0;
    const size_t nv = empty ? 1 : vertices, nt = empty ? 1 : triangles;
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
    auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt));
    if (!v || !t) {
        rtcReleaseGeometry(g);
        checkEmbree(device, "rtcSetNewGeometryBuffer");
        throw std::runtime_error("Embree: rtcSetNewGeometryBuffer failed");
    }
    if (empty) {
        std::memset(v, 0, 3 * sizeof(float));
        std::memset(t, 0, 3 * sizeof(unsigned));
    } else {
        std::memcpy(v, positions, nv * 3 * sizeof(float));
        std::memcpy(t, indices, nt * 3 * sizeof(unsigned));
    }
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    checkEmbree(device, "rtcAttachGeometry");
    return id;
}

}  // namespace sylva
