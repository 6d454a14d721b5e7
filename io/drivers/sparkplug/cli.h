// `rtplc sparkplug ...`: commissioning commands of the sparkplug driver.
#pragma once

namespace CLI {
class App;
}

namespace rtplc::sparkplug {

void add_commands(CLI::App& app);

}  // namespace rtplc::sparkplug
