// topics.refine.t: rost-cli's command of that name (docs/rost-cli.md).
#include "rostcli.hpp"

int main(int argc, char** argv) { return rost::cli::topicsRefineMain(rost::cli::Command::RefineT, argc, argv); }
