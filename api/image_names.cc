#include "api/image_names.h"

#include <cctype>

#include <fmt/format.h>

#include "engine/video/image_folder_source.h"

namespace glam::api {

std::string SafeImageName(const std::string& client_name) {
  const auto slash = client_name.find_last_of("/\\");
  std::string name = slash == std::string::npos ? client_name : client_name.substr(slash + 1);
  for (char& c : name) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '.' || c == '-' || c == '_';
    if (!ok) c = '_';
  }
  name.erase(0, name.find_first_not_of('.'));
  if (name.size() > 200) name.erase(0, name.size() - 200);
  return !name.empty() && HasImageExtension(name) ? name : std::string();
}

std::string NotAnImageNameMessage(const std::string& client_name) {
  return fmt::format("\"{}\" is not named like an image (.jpg, .jpeg, .png, .tif, .tiff, .bmp, .webp)", client_name);
}

std::string UncleanImageNameMessage(const std::string& name) {
  const std::string clean = SafeImageName(name);
  if (clean.empty()) return NotAnImageNameMessage(name);
  if (clean == name) return {};
  return fmt::format("\"{}\": image names in a set are letters, digits, '.', '-' and '_' only, not starting with "
                     "'.'; send it as \"{}\"", name, clean);
}

}  // namespace glam::api
