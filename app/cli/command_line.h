#pragma once
// The `hapticlab` program: builds the command tree, parses argv and runs the
// chosen command. Returns the exit status (app/cli/cli_errors.h lists them).

namespace hapticlab::app {

int hapticlab_main(int argc, char** argv);

}  // namespace hapticlab::app
