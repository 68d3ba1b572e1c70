// PLACEHOLDER while the volume kind is being written (issue 4); replaced by its spec reader.
#include "species/volume_spec.h"

namespace sylva {

VolumePtr parseRevolutionVolume(Params& p) {
    p.failHere("volume type \"revolution\" is not available yet");
}

}  // namespace sylva
