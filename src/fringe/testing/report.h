// Test helpers: the images a report embeds, decoded back (not part of the library API).
#pragma once

#include <zlib.h>

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
// that are base64 PNG or JPEG data URIs that decode.
inline std::vector<cv::Mat> EmbeddedImages(const std::string& html, int* sources) {
  std::vector<cv::Mat> out;
  *sources = 0;
  const std::string src = "<img src=\"";
  for (size_t at = html.find(src); at != std::string::npos; at = html.find(src, at + 1)) {
    ++*sources;
    const size_t begin = at + src.size(), end = html.find('"', begin);
    if (end == std::string::npos) continue;
    size_t b64 = std::string::npos;
    for (const std::string data : {"data:image/png;base64,", "data:image/jpeg;base64,"}) {
      if (html.compare(begin, data.size(), data) == 0) b64 = begin + data.size();
    }
    if (b64 == std::string::npos) continue;
    const cv::Mat m = cv::imdecode(DecodeBase64(html.substr(b64, end - b64)), cv::IMREAD_UNCHANGED);
    if (!m.empty()) out.push_back(m);
  }
  return out;
}

// The arrays of scene `index` of the page (io::ReportScene::bytes()), inflated; empty when the
// page has no such scene or its block does not inflate to the size it states.
inline std::vector<uint8_t> EmbeddedSceneBytes(const std::string& html, int index = 0) {
  const std::string id = "id=\"fringe-scene-" + std::to_string(index) + "-arrays\">";
  const size_t at = html.find(id);
  if (at == std::string::npos) return {};
  const size_t open = html.rfind("<script", at), stated = html.find("data-bytes=\"", open);
  if (open == std::string::npos || stated == std::string::npos || stated > at) return {};
  const size_t begin = at + id.size(), end = html.find("</script>", begin);
  if (end == std::string::npos) return {};
  const std::vector<uint8_t> deflated = DecodeBase64(html.substr(begin, end - begin));
  uLongf size = std::stoul(html.substr(stated + 12));
  std::vector<uint8_t> out(size);
  if (uncompress(out.data(), &size, deflated.data(), static_cast<uLong>(deflated.size())) != Z_OK ||
      size != out.size()) {
    return {};
  }
  return out;
}

}  // namespace fringe::io::testing
