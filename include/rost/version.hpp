#pragma once

// The library's version, and the git commit it was built from ("unknown"
// outside a git checkout), as compiled into the library.

namespace rost {

// "0.1.0": the project's version (major.minor.patch).
const char* version() noexcept;
// Short hash of the commit the build was configured at, or "unknown".
const char* gitCommit() noexcept;
// "0.1.0 (git 4a96891)": both, as `rost --version` prints them.
const char* versionString() noexcept;

} // namespace rost
