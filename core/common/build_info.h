#pragma once
// What this build is, for --version, the study database and reports:
// "hapticlab 0.1.0 (commit 0123456789ab)", with "-dirty-" and the first 12
// hex digits of the changes' SHA-256 after the commit when the tree had
// uncommitted changes (so two different dirty trees are two versions), and
// "unknown" without git (a source tarball: the version names it). The
// commit is taken at build time (cmake/write_build_info.cmake), not when
// CMake configured, so it follows every rebuild.

namespace hapticlab {

const char* software_version() noexcept;
const char* software_commit() noexcept;

}  // namespace hapticlab
