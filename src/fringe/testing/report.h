// Test helpers: the images a report embeds, decoded back (not part of the library API).
#pragma once

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace fringe::io::testing {

// Inverse of Base64 (the library only encodes).
inline std::vector<uint8_t> DecodeBase64(const std::string& s) {
  std::vector<uint8_t> out;
  uint32_t acc = 0;
  int bits = 0;
  for (char ch : s) {
    int v;
    if (ch >= 'A' && ch <= 'Z')
      v = ch - 'A';
    else if (ch >= 'a' && ch <= 'z')
      v = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9')
      v = ch - '0' + 52;
    else if (ch == '+')
      v = 62;
    else if (ch == '/')
      v = 63;
    else
      break;  // '=' padding
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<uint8_t>((acc >> bits) & 0xff));
    }
  }
  return out;
}

// Every <img> source of the page; *sources counts the src attributes, the result holds the ones
// that are base64 PNG data URIs that decode.
inline std::vector<cv::Mat> EmbeddedImages(const std::string& html, int* sources) {
  std::vector<cv::Mat> out;
  *sources = 0;
  const std::string src = "<img src=\"", data = "data:image/png;base64,";
  for (size_t at = html.find(src); at != std::string::npos; at = html.find(src, at + 1)) {
    ++*sources;
    const size_t begin = at + src.size(), end = html.find('"', begin);
    if (end == std::string::npos || html.compare(begin, data.size(), data) != 0) continue;
    const size_t b64 = begin + data.size();
    const cv::Mat m = cv::imdecode(DecodeBase64(html.substr(b64, end - b64)), cv::IMREAD_UNCHANGED);
    if (!m.empty()) out.push_back(m);
  }
  return out;
}

}  // namespace fringe::io::testing
