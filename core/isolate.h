// Reading a file with a library that is not safe on hostile input, in a child process.
//
// Fuzzing the loaders (tests/fuzz) found heap overflows inside the libraries themselves: libhdf5
// 1.10.8 (H5O__attr_exists on a corrupt object header) and libtorch 1.13's zip reader (miniz, on a
// corrupt central directory). Neither can be patched here, so a file a user points at is parsed in a
// forked child first: when the library crashes or aborts, only the child dies, and the caller gets an
// Error naming the file instead of a crash or a corrupted heap.
#pragma once

#include <functional>
#include <string>

namespace dd {

/// Runs `read` in a forked child process and returns the bytes it returned. When `read` throws, its
/// message is rethrown as an Error; when the child dies (a signal, a sanitizer's abort), throws
/// Error("<path>: the file is corrupt: reading it crashed <library> ..."). The child runs `read` on
/// one thread (OpenMP's pool is set to one); `read` must not start threads or pools of its own
/// (at::set_num_threads does: it hangs after a fork).
std::string read_in_child(const std::string& path, const std::string& library, const std::function<std::string()>& read);

/// With DD_READ_IN_PROCESS set in the environment, `read` runs in this process instead (for the
/// fuzzers' deep runs, which need the reading code's coverage; never for users).
///
/// Inputs whose reading crashed a child so far in this process.
int children_crashed();

}  // namespace dd
