#pragma once
// What this build is, for --version, the study database and reports:
// "hapticlab 0.1.0 (commit 0123456789ab)", with "-dirty" after the commit
// when the tree had uncommitted changes, and "unknown" without git. The
// commit is taken at build time (cmake/write_build_info.cmake), not when
// CMake configured, so it follows every rebuild.

namespace hapticlab {

const char* software_version() noexcept;
const char* software_commit() noexcept;

}  // namespace hapticlab
