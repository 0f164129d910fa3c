// hapticlab: command line entry point (the commands: app/command_line.cc).
#include "app/command_line.h"

int main(int argc, char** argv) { return hapticlab::app::hapticlab_main(argc, argv); }
