#pragma once

// Helpers for the vision and tool tests: real footage (fetched on demand by
// scripts/fetch-footage.sh into data/), temporary directories, running the
// rost executable and reading its CSV outputs.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace rost::testing {

inline std::string sourceDir() { return ROST_SOURCE_DIR; }

inline std::string dataDir() {
    if (const char* d = std::getenv("ROST_DATA_DIR"); d && *d) return d;
    return sourceDir() + "/data";
}

// Path of a footage file from a Debian package, fetching the package the
// first time (idempotent, serialised by a lock in the script). Empty when
// the fetch is impossible (no network, no apt): the caller skips, except
// under CI (CI=true), where footage is required and the test fails.
inline std::string footage(const std::string& package, const std::string& relative) {
    namespace fs = std::filesystem;
    const std::string path = dataDir() + "/" + package + "/" + relative;
    if (fs::exists(dataDir() + "/" + package + "/.unpacked") && fs::exists(path)) return path;
    const std::string cmd = sourceDir() + "/scripts/fetch-footage.sh --dir '" + dataDir() + "' " + package + " >/dev/null";
    const int rc = std::system(cmd.c_str());
    if (rc == 0 && fs::exists(path)) return path;
    return {};
}

inline bool requireFootage() {
    const char* ci = std::getenv("CI");
    return ci && std::string(ci) == "true";
}

#define ROST_FOOTAGE_OR_SKIP(var, package, relative)                                                        \
    const std::string var = ::rost::testing::footage(package, relative);                                     \
    if (var.empty()) {                                                                                       \
        if (::rost::testing::requireFootage())                                                               \
            FAIL() << "footage " << package << " could not be fetched (scripts/fetch-footage.sh), required in CI"; \
        GTEST_SKIP() << "footage " << package                                                                \
                     << " could not be fetched (scripts/fetch-footage.sh needs apt and a Debian mirror)";     \
    }

inline const char* kMire2 = "usr/share/visp-images-data/ViSP-images/mire-2";
inline const char* kDiver = "usr/share/doc/pd-extendedview/media/diver.mov";
inline const char* kVtest = "usr/share/doc/opencv-doc/examples/data/vtest.avi";

// A fresh temporary directory, removed at the end of the scope.
class TempDir {
public:
    TempDir() {
        std::string t = (std::filesystem::temp_directory_path() / "rost-test-XXXXXX").string();
        std::vector<char> buf(t.begin(), t.end());
        buf.push_back('\0');
        if (!::mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed");
        path_ = buf.data();
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::string& path() const { return path_; }
    std::string operator/(const std::string& name) const { return path_ + "/" + name; }

private:
    std::string path_;
};

struct RunResult {
    int exit_code = -1;
    std::string out, err;
};

// Runs a shell command, capturing stdout and stderr (stdin from /dev/null).
inline RunResult runShell(const std::string& command) {
    TempDir t;
    const std::string full = command + " </dev/null >'" + (t / "out") + "' 2>'" + (t / "err") + "'";
    const int status = std::system(full.c_str());
    RunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    auto slurp = [](const std::string& p) {
        std::ifstream f(p);
        std::stringstream ss;
        ss << f.rdbuf();
        return ss.str();
    };
    r.out = slurp(t / "out");
    r.err = slurp(t / "err");
    return r;
}

// A variable-frame-rate H.264 clip, as a phone records: 15 frames of
// 160x120, the first 10 at 10 a second (0, 0.1, ..., 0.9 s), then 5 at 2 a
// second (1.0, 1.5, ..., 3.0 s). False where ffmpeg is missing or cannot
// encode it.
inline const std::vector<int64_t> kVariableRateClipUs = {0,      100000, 200000,  300000,  400000,
                                                          500000, 600000, 700000,  800000,  900000,
                                                          1000000, 1500000, 2000000, 2500000, 3000000};
inline bool writeVariableRateClip(const std::string& path) {
    const std::string make = "command -v ffmpeg > /dev/null 2>&1 && ffmpeg -v error -f lavfi -i "
                             "testsrc=size=160x120:rate=10 -frames:v 15 -vf \"setpts='if(lt(N,10),N,10+(N-10)*5)/(10*TB)'\" "
                             "-fps_mode vfr -c:v libx264 -pix_fmt yuv420p -y '" + path + "' > /dev/null 2>&1";
    return std::system(make.c_str()) == 0;
}

inline std::string readText(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

inline void writeText(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << text;
}

// Splits text into lines (without the newline), dropping a final empty line.
inline std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::stringstream ss(text);
    std::string l;
    while (std::getline(ss, l)) out.push_back(l);
    return out;
}

inline std::vector<std::string> fields(const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string f;
    while (std::getline(ss, f, ',')) out.push_back(f);
    if (!line.empty() && line.back() == ',') out.push_back("");
    return out;
}

} // namespace rost::testing
