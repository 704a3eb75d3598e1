#pragma once

// A whole file's bytes in memory, for the large inputs a command reads once
// (a word stream's words.csv and positions.csv): internal to the library.

#include <string>
#include <string_view>

#include "aligned_buffer.hpp"
#include "rost/status.hpp"

namespace rost::text {

// A file of 2 MiB or more lands in a mapping of its own, aligned to and
// asked for huge pages (AlignedBuffer): the read faults in one page per
// 2 MiB instead of per 4 KiB and writes no zeros first. A std::string sized
// to the file (readFile's) is zero-filled, page by page, before the read
// copies over it; on the diver stream's 8 MB positions file that was 39-47 ms
// against 2-3 ms (in five runs of six) on the project's VM, where a fault is dear (bench/RESULTS.md,
// "Item 1, twelfth session").
class FileBytes {
public:
    std::string_view view() const noexcept { return {buf_.data(), size_}; }
    bool empty() const noexcept { return size_ == 0; }

private:
    friend Status readFile(const std::string& path, FileBytes& out);
    AlignedBuffer<char> buf_;
    std::size_t size_ = 0;
};

// readFile(path, std::string&)'s reading and errors, into `out`.
Status readFile(const std::string& path, FileBytes& out);

} // namespace rost::text
