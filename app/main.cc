// hapticlab: command line entry point (the commands: app/cli/command_line.cc).
#include "app/cli/command_line.h"

int main(int argc, char** argv) { return hapticlab::app::hapticlab_main(argc, argv); }
