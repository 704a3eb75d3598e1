#pragma once

// The thread settings' fallbacks are said on stderr once a process
// (src/core/realtime.cpp); internal.

namespace rost::detail {

// Forgets which fallbacks were said, so the next is said again: for a test
// that checks the line, whichever tests ran before it in the same process.
void forgetLoggedFallbacks() noexcept;

} // namespace rost::detail
