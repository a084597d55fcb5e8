// The one rule for a folder of images (io/image_folder.hpp): recursive, sorted by path, the
// same extensions everywhere (.webp included, any case), dot-names skipped, symbolic links to
// folders not followed, bounded, and clear errors.
#include <shadowsense/io/image_folder.hpp>

#include <doctest/doctest.h>

#include "common/files.hpp"
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

// Files with these relative paths (the rule looks at names only, never at the bytes).
void touch(const fs::path& dir, std::initializer_list<const char*> files) {
  for (const char* f : files) {
    fs::create_directories((dir / f).parent_path());
    std::ofstream(dir / f) << "x";
  }
}

std::vector<std::string> relative(const std::vector<fs::path>& found, const fs::path& dir) {
  std::vector<std::string> out;
  for (const fs::path& p : found) out.push_back(p.lexically_relative(dir).generic_string());
  return out;
}

} // namespace

TEST_CASE("find_images: recursive, sorted by path, every extension in any case, dot-names out") {
  const fs::path dir = tests::fresh_dir("image_folder_rule");
  touch(dir, {"b.webp",
              "a.PNG",
              "c.JpEg",
              "d.jpg",
              "e.bmp",
              "f.tif",
              "g.TIFF",
              "h.ppm",
              "i.pgm",
              "sub/z.png",
              "sub/deeper/y.png",
              "a2/x.png",
              ".hidden.png",
              ".cache/w.png",
              "sub/.git/v.png",
              "notes.txt",
              "png",
              "noext",
              "j.gif",
              "k.png.bak"});
  fs::create_directories(dir / "folder.png"); // a folder with an image's name is no image
  fs::create_directory_symlink(dir / "sub", dir / "link_to_sub");
  const std::vector<std::string> expected{
      "a.PNG",  "a2/x.png", "b.webp", "c.JpEg",           "d.jpg",    "e.bmp", "f.tif",
      "g.TIFF", "h.ppm",    "i.pgm",  "sub/deeper/y.png", "sub/z.png"};
  CHECK(relative(find_images(dir), dir) == expected);
  CHECK(relative(require_images(dir), dir) == expected);
  CHECK(image_extensions_text() == ".png .jpg .jpeg .bmp .tif .tiff .webp .ppm .pgm");
  CHECK(is_image_name("x.WebP"));
  CHECK_FALSE(is_image_name("x.gif"));
  CHECK_FALSE(is_image_name("webp"));
}

TEST_CASE("find_images: zero-padded frame numbers sort in capture order, folders stay together") {
  const fs::path dir = tests::fresh_dir("image_folder_order");
  touch(dir, {"frame_0010.png", "frame_0002.png", "frame_0001.png", "a/frame_0003.png", "a.png"});
  CHECK(relative(find_images(dir), dir) ==
        std::vector<std::string>{"a/frame_0003.png", "a.png", "frame_0001.png", "frame_0002.png",
                                 "frame_0010.png"});
}

TEST_CASE("find_images: bounded, and errors name the folder") {
  const fs::path dir = tests::fresh_dir("image_folder_errors");
  touch(dir, {"1.png", "2.png", "3.png", "x/readme.txt"});
  CHECK(find_images(dir, {.max_images = 3}).size() == 3);
  CHECK_THROWS_WITH_AS(find_images(dir, {.max_images = 2}),
                       (dir.string() + ": more than 2 images; expected at most that many").c_str(),
                       IoError);
  CHECK_THROWS_AS(find_images(dir, {.max_images = 0}), InvalidArgument);
  CHECK_THROWS_WITH_AS(find_images(dir / "1.png"),
                       (dir.string() + "/1.png: not a folder, expected a folder of images").c_str(),
                       IoError);
  CHECK_THROWS_WITH_AS(find_images(dir / "nope"),
                       (dir.string() + "/nope: missing, expected a folder of images").c_str(),
                       IoError);
  CHECK(find_images(dir / "x").empty());
  CHECK_THROWS_WITH_AS(require_images(dir / "x"),
                       (dir.string() +
                        "/x: holds no image (looked for .png .jpg .jpeg .bmp .tif .tiff .webp "
                        ".ppm .pgm, in sub-folders too)")
                           .c_str(),
                       IoError);
}
