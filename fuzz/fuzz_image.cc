// Image stacks: a small PNG / TIFF read as a grey image (OpenCV's decoders behind our checks).
#include "fringe/io/image_io.h"
#include "fringe/util/error.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const bool tiff = size > 1 && (data[0] == 'I' || data[0] == 'M');
  const auto path = fringe::fuzz::InputFile(data, size, tiff ? "image.tiff" : "image.png");
  try {
    fringe::io::ReadGrayImage(path);
  } catch (const fringe::Error&) {
  }
  return 0;
}
