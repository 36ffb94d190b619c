// What an output option may replace (commands.hpp: checkReplaceable).
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"

namespace cutsim::cli {

void checkReplaceable(const std::filesystem::path& target, const std::string& option,
                      const std::vector<std::filesystem::path>& inputs, std::string_view mark,
                      bool force) {
  std::error_code ec;
  if (!std::filesystem::exists(target, ec)) return;
  for (const std::filesystem::path& in : inputs) {
    std::error_code same;
    if (!in.empty() && std::filesystem::equivalent(target, in, same))
      throw InvalidInput(option, target.string() + " is " + in.string() +
                                     ", an input of this command: it is never replaced");
  }
  if (force) return;
  std::ifstream f(target, std::ios::binary);
  std::string head(4096, '\0');
  f.read(head.data(), std::streamsize(head.size()));
  head.resize(std::size_t(f.gcount()));
  if (!mark.empty() && head.find(mark) != std::string::npos) return;
  throw InvalidInput(option, target.string() +
                                 " exists and was not written by this command: name another file, "
                                 "remove it, or pass --force to replace it");
}

}  // namespace cutsim::cli
