#include "pipeline/batch/run_log.h"

#include <unistd.h>

#include <vector>

#include "core/atomic_file.h"
#include "core/input_file.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/output_lock.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> readLines(const fs::path& file) {
    std::vector<std::string> lines;
    std::error_code ec;
    if (!fs::exists(file, ec)) return lines;
    const std::string data = readInputFile(file, kMaxRunLogBytes, "run log");
    size_t start = 0;
    for (size_t nl; (nl = data.find('\n', start)) != std::string::npos; start = nl + 1) {
        if (nl > start) lines.emplace_back(data, start, nl - start);
    }
    return lines;  // (a torn last line cannot happen: the file is only ever renamed into place)
}

void writeLines(const fs::path& file, const std::vector<std::string>& lines) {
    std::string bytes;
    for (const std::string& l : lines) bytes += l + "\n";
    writeFileAtomic(file, bytes);
}

}  // namespace

std::string runLogName(int shardIndex, int shardCount) {
    return "runs" + manifestName(shardIndex, shardCount).substr(std::string("manifest").size());
}

nlohmann::json runLine(const std::string& command) {
    const LockHolder me = currentHolder("");
    nlohmann::json j;
    j["command"] = command;
    j["started"] = me.started;
    j["host"] = me.host;
    j["pid"] = me.pid;
    j["sylva"] = SYLVA_VERSION;
    return j;
}

void RunLog::start(const nlohmann::json& line, int64_t recordedNow) {
    std::vector<std::string> lines = readLines(file_);
    if (!lines.empty()) {
        auto last = nlohmann::json::parse(lines.back(), nullptr, false);
        if (last.is_object() && last.value("status", "") == "running") {
            last["status"] = "interrupted";
            if (last.contains("already_built")) {
                last["built"] = recordedNow - last.value("already_built", int64_t{0});
            }
            lines.back() = last.dump();
        }
    }
    lines.push_back(line.dump());
    writeLines(file_, lines);
}

void RunLog::finish(const nlohmann::json& line) {
    std::vector<std::string> lines = readLines(file_);
    if (lines.empty()) lines.emplace_back();
    lines.back() = line.dump();
    writeLines(file_, lines);
}

}  // namespace sylva
