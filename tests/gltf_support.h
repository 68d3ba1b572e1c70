// A GLB read back with tinygltf, for the tests of the mesh writers.
#pragma once

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <string>

namespace sylva::test {

// The model of a GLB in memory; a load error or warning fails the calling test.
inline tinygltf::Model loadGlb(const std::string& glb) {
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    const bool ok = loader.LoadBinaryFromMemory(&model, &err, &warn,
                                                reinterpret_cast<const unsigned char*>(glb.data()),
                                                static_cast<unsigned>(glb.size()));
    EXPECT_TRUE(ok) << err;
    EXPECT_TRUE(warn.empty()) << warn;
    return model;
}

}  // namespace sylva::test
