#include "common/run/atomic_file.hpp"

#include <unistd.h>

#include <fstream>
#include <stdexcept>

namespace cosim::protocol {

std::filesystem::path part_path(const std::filesystem::path& file, PartName name) {
  std::string part = file.string() + ".part";
  if (name == PartName::PerProcess) part += std::to_string(::getpid());
  return part;
}

void rename_or_throw(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::error_code ec;
  std::filesystem::rename(from, to, ec);
  if (ec)
    throw std::runtime_error("cannot rename " + from.string() + " to " + to.string() + ": " +
                             ec.message());
}

void write_text_atomically(const std::filesystem::path& file, const std::string& text,
                           PartName name) {
  write_atomically(
      file,
      [&](const std::filesystem::path& part) {
        std::ofstream out(part, std::ios::binary | std::ios::trunc);
        out << text;
        out.flush();
        if (!out)
          throw std::runtime_error("cannot write " + file.string() +
                                   " (disk full or directory not writable?)");
      },
      name);
}

}  // namespace cosim::protocol
