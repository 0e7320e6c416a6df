#include "reefgen/model/shipped.hpp"

#include <cstdlib>
#include <stdexcept>

#include "reefgen/install.hpp"

namespace reefgen::model {

std::filesystem::path resolve_model_path(const std::string& flag) {
  if (!flag.empty()) return flag;
  if (const char* env = std::getenv("REEFGEN_MODEL"); env && *env) return env;
  const std::filesystem::path installed = installed_data("models");
  const std::filesystem::path shipped =
      (installed.empty() ? std::filesystem::path(REEFGEN_MODELS_DIR) : installed) / kShippedModelFile;
  if (!std::filesystem::exists(shipped))
    throw std::runtime_error(shipped.string() + ": the shipped model is missing (a partial checkout?); "
                             "restore models/ from the repository or pass -m GENERATOR.pt");
  return shipped;
}

}  // namespace reefgen::model
