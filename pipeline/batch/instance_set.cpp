#include "pipeline/batch/instance_set.h"

#include <algorithm>
#include <iterator>

namespace sylva {

void InstanceSet::insert(int64_t position) {
    auto next = runs_.upper_bound(position);  // first run beginning after `position`
    if (next != runs_.begin()) {
        auto prev = std::prev(next);
        if (position < prev->second) return;  // inside it
        if (position == prev->second) {       // extends it, perhaps up to the next run
            ++prev->second;
            ++size_;
            if (next != runs_.end() && next->first == prev->second) {
                prev->second = next->second;
                runs_.erase(next);
            }
            return;
        }
    }
    ++size_;
    if (next != runs_.end() && next->first == position + 1) {  // extends the next run down
        const int64_t end = next->second;
        runs_.erase(next);
        runs_.emplace(position, end);
        return;
    }
    runs_.emplace_hint(next, position, position + 1);
}

bool InstanceSet::contains(int64_t position) const {
    auto it = runs_.upper_bound(position);
    return it != runs_.begin() && position < std::prev(it)->second;
}

int64_t InstanceSet::countIn(int64_t lo, int64_t hi) const {
    int64_t n = 0;
    auto it = runs_.upper_bound(lo);
    if (it != runs_.begin()) --it;
    for (; it != runs_.end() && it->first < hi; ++it) {
        const int64_t b = std::max(lo, it->first), e = std::min(hi, it->second);
        if (b < e) n += e - b;
    }
    return n;
}

int64_t InstanceSet::nextPresent(int64_t from, int64_t hi) const {
    if (from >= hi) return hi;
    auto it = runs_.upper_bound(from);
    if (it != runs_.begin() && from < std::prev(it)->second) return from;
    return it == runs_.end() ? hi : std::min(hi, it->first);
}

int64_t InstanceSet::nextMissing(int64_t from, int64_t hi) const {
    if (from >= hi) return hi;
    auto it = runs_.upper_bound(from);
    if (it != runs_.begin() && from < std::prev(it)->second) {
        return std::min(hi, std::prev(it)->second);  // runs are never adjacent
    }
    return from;
}

}  // namespace sylva
