#pragma once
// Small filesystem helpers shared by the readers and writers in host/data.
#include <filesystem>
#include <string>
#include <vector>

namespace nova::data {

namespace fs = std::filesystem;

// Regular files in `dir` whose extension (case-insensitive, with the dot) is in `exts`,
// sorted by file name (the order the reference code's sorted(os.listdir) gives).
std::vector<fs::path> list_files(const fs::path& dir, const std::vector<std::string>& exts);

// Sub-folders of `dir` with all-digit names, sorted by their number.
std::vector<std::pair<int, fs::path>> numbered_subdirs(const fs::path& dir);

// The file's bytes; error "FILE: cannot open" when it cannot be opened.
std::string read_text(const fs::path& file);

// Writes into a temporary sibling of `target` and renames it into place at the end, so a
// failed run leaves nothing behind: construct, fill path(), then commit(). The destructor
// removes the temporary folder unless committed.
class StagedDir {
 public:
  StagedDir(const fs::path& target, bool replace_existing);
  ~StagedDir();
  StagedDir(const StagedDir&) = delete;
  StagedDir& operator=(const StagedDir&) = delete;
  const fs::path& path() const { return tmp_; }
  void commit();

 private:
  fs::path target_, tmp_;
  bool replace_ = false, committed_ = false;
};

}  // namespace nova::data
