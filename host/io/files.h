// The files a user names, checked and opened the one way, so that every refusal names the path and what is wrong
// with it (docs/guide/hardening.md). Without it the system says less: a directory opens for reading on Linux and
// fails at the first read ("Is a directory", no path), a stream opened for writing on a directory or in a folder
// that does not exist just fails, and std::filesystem's errors come in its own words. Every reader and writer of
// host/io/ (and the jobs that write files of their own) go through these.
#pragma once

#include <fstream>
#include <initializer_list>
#include <string>

namespace rtu::host {

// A file to read: throws Error "PATH: file not found", "PATH: is a directory, not a file" or "PATH: not a regular
// file" (a device, a pipe: the readers need its size).
void check_input_file(const std::string& path);

// A file to write (created or replaced): throws Error "PATH: is a directory, not a file (name a file to write)",
// "PATH: cannot write: the folder DIR does not exist" or "PATH: cannot write: DIR is not a folder". Devices such
// as /dev/null pass.
void check_output_file(const std::string& path);
// check_output_file for each path given (empty ones skipped): a command that writes several files checks them all
// before its job runs, so a bad path is refused at once, not after minutes of work.
void check_output_files(std::initializer_list<std::string> paths);

// check_output_file, then the file opened for writing with `mode` (std::ios::out is added; trunc unless app);
// throws Error "PATH: cannot open for writing (REASON)" when it does not open.
std::ofstream open_output(const std::string& path, std::ios::openmode mode = std::ios::trunc);

// Flushes `out`, opened on `path`; throws Error "PATH: write error (REASON)" when not all of it was written (a
// full disk).
void finish_output(std::ofstream& out, const std::string& path);

}  // namespace rtu::host
