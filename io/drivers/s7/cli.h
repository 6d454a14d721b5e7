// `rtplc s7 ...`, the S7 driver's commissioning commands (cli.cpp).
#pragma once

namespace CLI {
class App;
}

namespace rtplc::s7 {

void add_commands(CLI::App& app);

}  // namespace rtplc::s7
