// Loaded into a tool process with LD_PRELOAD by test_tool: counts the threads
// the process starts (every pthread_create, std::thread's included) and, at
// exit, writes the count to the file named by ROST_TEST_THREADS_FILE. With
// ROST_TEST_THREADS_LIMIT=N, the threads past the first N fail to start
// (EAGAIN, as under a process limit). Not built under a sanitizer, whose
// runtime must come first in a process.

#include <dlfcn.h>
#include <pthread.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>

namespace {

std::atomic<int> started{0};

using CreateFn = int (*)(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*);

struct Report {
    ~Report() {
        const char* path = std::getenv("ROST_TEST_THREADS_FILE");
        if (path == nullptr) return;
        if (std::FILE* f = std::fopen(path, "w")) {
            std::fprintf(f, "%d\n", started.load());
            std::fclose(f);
        }
    }
} report;

} // namespace

extern "C" int pthread_create(pthread_t* thread, const pthread_attr_t* attr, void* (*run)(void*), void* arg) {
    static const auto real = reinterpret_cast<CreateFn>(dlsym(RTLD_NEXT, "pthread_create"));
    static const char* limit = std::getenv("ROST_TEST_THREADS_LIMIT");
    if (limit != nullptr && started.load() >= std::atoi(limit)) return EAGAIN;
    started.fetch_add(1);
    return real(thread, attr, run, arg);
}
