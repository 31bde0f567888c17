// Files that appear whole or not at all. Each is written under a temporary name beside its
// final one and renamed when complete (a rename within one folder is atomic on POSIX), so a
// reader (ParaView, a plot script, a restart) never sees half a file, and a write that fails
// (a full disk, a folder gone) leaves nothing behind. Used by every output writer: field and
// sheet snapshots, their XDMF indexes, the provenance records. Checkpoints use the same name
// rule through CheckpointWriter (common/run/checkpoint_file.hpp).
#pragma once

#include <filesystem>
#include <string>
#include <system_error>
#include <utility>

namespace cosim::protocol {

/// Who may write the same final file at the same time.
enum class PartName {
  Shared,      ///< one writer per file: FILE.part (a stale one from a killed run is overwritten)
  PerProcess,  ///< several processes may write the same file (both servers' copy of the
               ///< scene): FILE.part<pid>, so that they never write into each other's part
};

/// The temporary name `file` is written under.
std::filesystem::path part_path(const std::filesystem::path& file, PartName name = PartName::Shared);

/// Renames `from` to `to`; a failure throws std::runtime_error naming both.
void rename_or_throw(const std::filesystem::path& from, const std::filesystem::path& to);

/// Calls `write(part)`, which writes the whole file at `part`, then renames it to `file`.
/// If `write` or the rename throws, the part file is removed and the exception passed on.
template <class Write>
void write_atomically(const std::filesystem::path& file, Write&& write,
                      PartName name = PartName::Shared) {
  const std::filesystem::path part = part_path(file, name);
  try {
    std::forward<Write>(write)(part);
    rename_or_throw(part, file);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(part, ec);  // a full disk leaves no part file behind
    throw;
  }
}

/// Writes `text` as the whole content of `file`, atomically. A failure throws
/// std::runtime_error "cannot write FILE (disk full or directory not writable?)".
void write_text_atomically(const std::filesystem::path& file, const std::string& text,
                           PartName name = PartName::Shared);

}  // namespace cosim::protocol
