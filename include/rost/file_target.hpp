#pragma once

// Where a write to a path lands, and the temporary file staged beside it
// before a rename puts it in place. C++17-clean: the ROS bag writer, built
// as C++17 for rosbag's headers, stages its bags with these, as
// writeFileAtomic (rost/text_io.hpp) does every other file.

#include <string>

#include "rost/status.hpp"

namespace rost::text {

// The file a write to `path` replaces: `path`, or where its symbolic links
// lead (a checkpoint linked into a store is written there, the link kept; a
// link to a file not made yet leads to the file to make). A loop of links
// (40 hops) is an error, as the kernel's lookups give.
Status linkTarget(const std::string& path, std::string& target);

// The permissions a file written to `path` gets: those of the regular file
// there (without setuid, setgid or sticky), else what a new file gets under
// this process's umask (0666 less it).
unsigned fileModeFor(const std::string& path);

// A new, empty file beside `target`, named "DIR/.NAME.tmpXXXXXX" (mkstemp: a
// name no other file has), with the permissions fileModeFor(target) gives.
// Its directory goes to `dir`, its name to `tmp`. Returns its descriptor, or
// -1 with errno set.
int makeTemporaryBeside(const std::string& target, std::string& dir, std::string& tmp);

} // namespace rost::text
