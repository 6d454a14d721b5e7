// `rtplc gpio ...`, the gpio driver's commissioning commands (cli.cpp).
#pragma once

namespace CLI {
class App;
}

namespace rtplc::gpio {

struct ChipOps;

void add_commands(CLI::App& app);
// The same over another chip implementation (the host tests' fake chips).
void add_commands_with(CLI::App& app, const ChipOps& ops);

}  // namespace rtplc::gpio
