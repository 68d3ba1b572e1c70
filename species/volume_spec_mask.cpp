// PLACEHOLDER while the volume kind is being written (issue 4); replaced by its spec reader.
#include "species/volume_spec.h"

namespace sylva {

VolumePtr parseMaskRevolutionVolume(Params& p) {
    p.failHere("volume type \"mask-revolution\" is not available yet");
}

}  // namespace sylva
