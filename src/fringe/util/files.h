// File-system helpers shared by every reader and writer. Inputs are untrusted (docs/formats.md,
// "Untrusted inputs"): names read from data files are checked before use, outputs are written
// under a temporary name and renamed at the end (a failure never leaves a half-written file or
// folder behind), and an output never replaces an input of the same command nor a folder that
// fringe did not write.
//
// Thread safety: the functions may be called from several threads; the temporary-path registry
// behind signal cleanup is internally synchronised.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace fringe::util {

namespace fs = std::filesystem;

// Name of the marker file fringe puts into every output folder it writes. A folder output only
// replaces an existing folder that holds this marker (or is empty, or matches a legacy layout
// the caller recognises), so `--out` can never delete a user's own folder.
inline constexpr const char* kOutputMarkerName = ".fringe-output";

struct OutputFolderOptions {
  // Files and folders the command reads. The output folder must not be one of them nor contain
  // one (replacing it would delete the input); checked before anything is written.
  std::vector<fs::path> inputs;
  // Recognises a folder fringe wrote before the marker existed (e.g. an old `fringe demo`
  // output) by its layout, so that such a folder may still be replaced. Null: none.
  std::function<bool(const fs::path& dir)> legacy_layout;
  // Take over the temporary folder a killed run writing the same `dir` left (its process no
  // longer exists; the newest such), with what it holds below kResumeFolder, instead of starting
  // empty: write() finds there what the interrupted run kept for reuse. Everything else in it is
  // removed first, so nothing of the interrupted run becomes an output by accident.
  bool resume = false;
};

// The one entry of a taken-over temporary folder that is kept (OutputFolderOptions::resume).
inline constexpr const char* kResumeFolder = ".resume";

// Calls write(tmp_path) with a temporary path in the same directory (same extension, so
// extension-driven writers such as cv::imwrite work), then renames it to `path`. On any
// exception the temporary is removed and the exception propagates; errors name `path`, never
// the temporary. Throws fringe::Error when the directory does not exist or is not writable.
// Temporaries left by killed runs for the same `path` are removed first; a SIGINT/SIGTERM/SIGHUP
// during write() removes the temporary before the process ends.
void WriteAtomically(const fs::path& path, const std::function<void(const fs::path& tmp)>& write);

// Closes a file stream written for `path` (usually its WriteAtomically temporary) and throws
// fringe::Error("<path>: cannot write: <reason>") when any write failed: a full disk (ENOSPC), a
// quota (EDQUOT) or a file size limit (EFBIG) show only in the stream's state, and the last
// buffered bytes reach the file only at close, so the state is checked after closing.
void CloseOutput(std::ofstream& out, const fs::path& path);

// Same for a whole output folder: write(tmp_dir) fills a fresh temporary folder (which gets the
// marker file) that then replaces `dir`. An existing `dir` is replaced only when
// CheckOutputFolder() allows it, and removed only after the new one is complete. Errors thrown by
// write() that name a path inside the temporary folder are rethrown naming the same path inside
// `dir` (the user never sees the hidden temporary); the temporary folder is removed.
void WriteFolderAtomically(const fs::path& dir, const OutputFolderOptions& options,
                           const std::function<void(const fs::path& tmp_dir)>& write);
inline void WriteFolderAtomically(const fs::path& dir,
                                  const std::function<void(const fs::path& tmp_dir)>& write) {
  WriteFolderAtomically(dir, OutputFolderOptions{}, write);
}

// Several output files of one command committed together: Stage() checks the location and
// returns a temporary path beside each output (same extension, so extension-driven writers
// work); the caller writes every output to its temporary (Write() does both and names the
// user's path in errors), then Commit() renames them all into place. A failure before Commit() (an
// exception, a signal) leaves no output and no temporary: the destructor removes uncommitted
// temporaries.
class OutputTransaction {
 public:
  OutputTransaction() = default;
  ~OutputTransaction();
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;

  fs::path Stage(const fs::path& path);
  // Stage(path), then write(tmp): an error thrown by write() that names the temporary (a
  // writer's checked close on a full disk, a filesystem error) is rethrown naming `path`, so the
  // user never sees the hidden name. What was written stays staged until Commit().
  void Write(const fs::path& path, const std::function<void(const fs::path& tmp)>& write);
  void Commit();

 private:
  struct Entry {
    fs::path path, tmp;
    std::shared_ptr<void> signal_cleanup;  // keeps `tmp` registered for removal on a signal
  };
  std::vector<Entry> entries_;
};

// Early checks for a command's outputs, to run before any computation (docs/formats.md). The one
// output rule of every command: an output is not, does not contain, and does not lie inside any
// of the command's inputs (files and folders, also through links).
// CheckOutputFile: the parent folder exists and is writable, `path` is not a folder, and the rule
// holds for `inputs`. CheckOutputFolder: the parent exists and is writable, the rule holds for
// options.inputs, and an existing `dir` is empty, holds kOutputMarkerName or matches
// options.legacy_layout. Both throw fringe::Error naming the path.
void CheckOutputFile(const fs::path& path, const std::vector<fs::path>& inputs = {});
void CheckOutputFolder(const fs::path& dir, const OutputFolderOptions& options = {});
// Several output files of one command must be distinct (two flags naming one file would make
// the second overwrite the first).
void CheckDistinctOutputs(const std::vector<fs::path>& outputs);

// Names read from data files (image names in a manifest, files named by a scan folder): a
// relative path inside its folder, subfolders allowed ("calibration/target.json"), with no
// empty, "." or ".." component, no absolute path, no backslash or control character, and, when
// `extensions` is not empty, one of those extensions (lower case with the dot, compared case
// insensitively). Throws fringe::Error("<context>: <what> '<name>': <problem>").
void CheckRelativeName(const std::string& name, const std::string& context,
                       const std::vector<std::string>& extensions = {},
                       const std::string& what = "file name");
// The same for a list, plus: no name twice.
void CheckRelativeNames(const std::vector<std::string>& names, const std::string& context,
                        const std::vector<std::string>& extensions = {},
                        const std::string& what = "file name");
// Image extensions fringe reads and writes (".png", ".tif", ".tiff", ".bmp", ".jpg", ".jpeg",
// ".pgm", ".ppm", ".pnm").
const std::vector<std::string>& ImageExtensions();
// True when `path`'s extension is one of `extensions` (case insensitive).
bool HasExtension(const fs::path& path, const std::vector<std::string>& extensions);

// Throws fringe::Error("<path>: <what>: no such file") when `path` is not a regular file.
void RequireFile(const fs::path& path, const std::string& what = "file");
// Throws fringe::Error when `path` is not a directory.
void RequireDirectory(const fs::path& path, const std::string& what = "folder");

// Size of a regular file in bytes; throws fringe::Error naming the file when it cannot be read.
std::uintmax_t FileSizeBytes(const fs::path& path);

// Reads a whole text file; throws fringe::Error naming the file on failure, and when the file
// is larger than max_bytes (default 256 MiB: no text input of fringe comes near it).
std::string ReadTextFile(const fs::path& path, std::uintmax_t max_bytes = std::uintmax_t{1} << 28);

// Environment variable as a flag: set to something other than "", "0", "false".
bool EnvFlag(const char* name);

}  // namespace fringe::util
