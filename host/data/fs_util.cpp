// Filesystem helpers for host/data (see fs_util.hpp).
#include "data/fs_util.hpp"

#include <algorithm>
#include <random>
#include <unistd.h>
#include <utility>

#include "nova/runtime/error.hpp"
#include "runtime/read_file.hpp"

namespace nova::data {

namespace {
std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}
}  // namespace

std::vector<fs::path> list_files(const fs::path& dir, const std::vector<std::string>& exts) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    const std::string ext = lower(e.path().extension().string());
    if (std::find(exts.begin(), exts.end(), ext) != exts.end()) out.push_back(e.path());
  }
  if (ec) throw Error(dir.string() + ": cannot list folder (" + ec.message() + ")");
  std::sort(out.begin(), out.end(),
            [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); });
  return out;
}

std::vector<std::pair<int, fs::path>> numbered_subdirs(const fs::path& dir) {
  std::vector<std::pair<int, fs::path>> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_directory()) continue;
    const std::string name = e.path().filename().string();
    if (name.empty() || name.size() > 6 ||
        !std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    out.emplace_back(std::stoi(name), e.path());
  }
  if (ec) throw Error(dir.string() + ": cannot list folder (" + ec.message() + ")");
  std::sort(out.begin(), out.end());
  return out;
}

std::string read_text(const fs::path& file) {
  std::optional<std::string> text = read_file(file.string());
  if (!text) throw Error(file.string() + ": cannot open");
  return std::move(*text);
}

StagedDir::StagedDir(const fs::path& target, bool replace_existing)
    : target_(fs::absolute(target)), replace_(replace_existing) {
  if (target_.filename().empty()) target_ = target_.parent_path();
  std::error_code ec;
  if (fs::exists(target_, ec) && !replace_)
    throw Error(target_.string() + ": already exists (choose another --out, or pass --force)");
  if (!fs::is_directory(target_.parent_path(), ec))
    throw Error(target_.parent_path().string() + ": output parent folder does not exist");
  // A per-process, per-instance name, so two runs never share a temporary folder.
  std::random_device rd;
  tmp_ = target_.parent_path() / ("." + target_.filename().string() + ".tmp-" +
                                  std::to_string(::getpid()) + "-" + std::to_string(rd()));
  if (!fs::create_directory(tmp_, ec))
    throw Error(tmp_.string() + ": cannot create temporary folder (" + ec.message() + ")");
}

StagedDir::~StagedDir() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(tmp_, ec);
}

void StagedDir::commit() {
  std::error_code ec;
  fs::path old;
  if (fs::exists(target_, ec)) {
    old = target_.parent_path() / (tmp_.filename().string() + ".old");
    fs::rename(target_, old, ec);
    if (ec) throw Error(target_.string() + ": cannot replace (" + ec.message() + ")");
  }
  fs::rename(tmp_, target_, ec);
  if (ec) {
    const std::string why = ec.message();
    if (!old.empty()) fs::rename(old, target_, ec);
    throw Error(target_.string() + ": cannot move the output into place (" + why + ")");
  }
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

}  // namespace nova::data
