// libsylva_oiio.so: OpenImageIO behind volumes/oiio_module.h's table.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <string>

#include "volumes/oiio_module.h"

namespace sylva {
namespace {

std::string oneLine(std::string s) {
    std::replace(s.begin(), s.end(), '\n', ' ');
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

bool readFile(const std::string& path, const std::function<void(int, int, int, int)>& check,
              ImageFile& img, std::string& error) {
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
        error = oneLine(OIIO::geterror());
        if (error.empty()) error = "no image reader recognises it";
        return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    check(spec.width, spec.height, spec.nchannels, spec.depth);
    img.width = spec.width;
    img.height = spec.height;
    img.channels = spec.nchannels;
    img.alphaChannel = spec.alpha_channel < spec.nchannels ? spec.alpha_channel : -1;
    switch (spec.format.basetype) {
        case OIIO::TypeDesc::UINT8:
            img.integerMax = 255.0;
            break;
        case OIIO::TypeDesc::INT8:
            img.integerMax = 127.0;
            break;
        case OIIO::TypeDesc::UINT16:
            img.integerMax = 65535.0;
            break;
        case OIIO::TypeDesc::INT16:
            img.integerMax = 32767.0;
            break;
        case OIIO::TypeDesc::UINT32:
            img.integerMax = 4294967295.0;
            break;
        case OIIO::TypeDesc::INT32:
            img.integerMax = 2147483647.0;
            break;
        default:
            img.integerMax = 0.0;
            break;  // half, float, double
    }
    img.pixels.resize(static_cast<size_t>(img.width) * img.height * img.channels);
    if (!in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::FLOAT, img.pixels.data())) {
        error = oneLine(in->geterror());
        if (error.empty()) error = "its pixels cannot be read";
        return false;
    }
    in->close();
    return true;
}

bool decode(const std::string& bytes, const std::string& name, int channels, uint8_t fill,
            std::vector<uint8_t>& px, int& w, int& h, int& imageChannels, std::string& error) {
    OIIO::Filesystem::IOMemReader mem(bytes.data(), bytes.size());
    auto in = OIIO::ImageInput::open(name, nullptr, &mem);
    if (!in) {
        error = oneLine(OIIO::geterror());
        return false;
    }
    w = in->spec().width;
    h = in->spec().height;
    imageChannels = in->spec().nchannels;
    px.assign(static_cast<size_t>(std::max(w, 0)) * std::max(h, 0) * channels, fill);
    const int read = std::min(imageChannels, channels);
    if (w <= 0 || h <= 0 || read <= 0 ||
        !in->read_image(0, 0, 0, read, OIIO::TypeDesc::UINT8, px.data(), channels)) {
        error = oneLine(in->geterror());
        return false;
    }
    in->close();
    return true;
}

bool encodeJpeg(int width, int height, const uint8_t* rgb, int quality, std::string& out,
                std::string& error) {
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    auto writer = OIIO::ImageOutput::create("jpg");
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("Compression", "jpeg:" + std::to_string(quality));
    if (!writer || !writer->set_ioproxy(&proxy) || !writer->open("memory.jpg", spec) ||
        !writer->write_image(OIIO::TypeDesc::UINT8, rgb) || !writer->close()) {
        error = oneLine(writer ? writer->geterror() : OIIO::geterror());
        return false;
    }
    out.assign(bytes.begin(), bytes.end());
    return true;
}

const OiioModule kModule = {readFile, decode, encodeJpeg};

}  // namespace
}  // namespace sylva

extern "C" __attribute__((visibility("default"))) const sylva::OiioModule* sylva_oiio_module() {
    return &sylva::kModule;
}
