// `rtplc modbus ...`, the Modbus driver's commissioning commands (cli.cpp).
#pragma once

namespace CLI {
class App;
}

namespace rtplc::modbus {

void add_commands(CLI::App& app);

}  // namespace rtplc::modbus
