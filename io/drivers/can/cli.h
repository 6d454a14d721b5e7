// `rtplc can ...`, the CAN driver's commissioning commands (cli.cpp).
#pragma once

namespace CLI {
class App;
}

namespace rtplc::can {

void add_commands(CLI::App& app);

}  // namespace rtplc::can
