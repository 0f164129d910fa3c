#pragma once
// The files a command wrote into its output folder, recorded there, so that
// its next run into the same folder leaves one run's results: the files the
// earlier run wrote and this one did not (another study's report.html, the
// figures of a run before --no-plots, a transfer.md after a design changed)
// are removed. Only files a record lists are ever removed, never one the
// command did not write (a user's own notes in the folder stay).
//
// The record is DIR/.hapticlab-outputs, one path per line relative to DIR,
// written complete or absent (output_file.h) after the removal.

#include <filesystem>
#include <string_view>
#include <vector>

namespace hapticlab {

inline constexpr std::string_view kOutputRecordName = ".hapticlab-outputs";

// `written`: the files this run wrote, inside `dir` (absolute or relative to
// the working directory, as `dir`). Removes the regular files the previous
// record lists that `written` does not, and the folders that leaves empty;
// a listed path that leaves `dir` ("..", absolute) or is not a regular file
// (a link, a folder) is not touched. Returns the removed files. Throws
// OutputFileError when the record cannot be written, or a file of
// `written` lies outside `dir`.
std::vector<std::filesystem::path> replace_output_record(const std::filesystem::path& dir,
                                                         const std::vector<std::filesystem::path>& written);

}  // namespace hapticlab
