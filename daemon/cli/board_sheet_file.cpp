#include "daemon/cli/board_sheet_file.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <vector>

#include "common/atomic_file.h"
#include "common/input_error.h"

namespace parallax::cli {
namespace {

constexpr double kPointsPerMm = 72.0 / 25.4;

std::string pdfText(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '(' || c == ')' || c == '\\') out += '\\';
    out += c;
  }
  return "(" + out + ")";
}

// A one-page PDF 1.4 by hand: five objects, the content stream uncompressed (a few thousand
// rectangles), Helvetica from the standard 14 fonts (no embedding needed).
std::string boardPdf(const BoardSheet& sheet, const std::string& caption) {
  // The smallest landscape ISO page that holds the sheet and a caption strip.
  constexpr double kCaptionMm = 14.0, kEdgeMm = 8.0;
  double pageW = 297.0, pageH = 210.0;
  for (const auto& [w, h] : {std::pair{297.0, 210.0}, std::pair{420.0, 297.0}}) {
    pageW = w;
    pageH = h;
    if (sheet.widthMm + 2 * kEdgeMm <= w && sheet.heightMm + kCaptionMm + 2 * kEdgeMm <= h) break;
    pageW = sheet.widthMm + 2 * kEdgeMm;
    pageH = sheet.heightMm + kCaptionMm + 2 * kEdgeMm;
  }
  // Sheet centred above the caption strip; PDF's y runs up from the page's bottom.
  const double left = 0.5 * (pageW - sheet.widthMm);
  const double top = kEdgeMm + 0.5 * (pageH - 2 * kEdgeMm - kCaptionMm - sheet.heightMm);
  const auto pt = [](double mm) { return fmt::format("{:.3f}", mm * kPointsPerMm); };
  std::string content = "0 g\n";
  for (const cv::Rect2d& r : sheet.black) {
    content += fmt::format("{} {} {} {} re f\n", pt(left + r.x), pt(pageH - (top + r.y + r.height)),
                           pt(r.width), pt(r.height));
  }
  // The scale bar: 100 mm with a tick every 10 mm, under the sheet.
  const double barY = pageH - (top + sheet.heightMm + 5.0), barX = left;
  content +=
      fmt::format("0 G 0.6 w {} {} m {} {} l S\n", pt(barX), pt(barY), pt(barX + 100.0), pt(barY));
  for (int t = 0; t <= 10; ++t) {
    const double x = barX + 10.0 * t, tick = t % 5 == 0 ? 3.0 : 1.5;
    content += fmt::format("{} {} m {} {} l S\n", pt(x), pt(barY), pt(x), pt(barY + tick));
  }
  content += fmt::format("BT /F1 8 Tf {} {} Td {} Tj ET\n", pt(barX + 104.0), pt(barY),
                         pdfText("100 mm: measure it; print at 100% (no fit to page)"));
  content +=
      fmt::format("BT /F1 8 Tf {} {} Td {} Tj ET\n", pt(barX), pt(barY - 5.0), pdfText(caption));

  const std::vector<std::string> objects = {
      "<< /Type /Catalog /Pages 2 0 R >>",
      "<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
      fmt::format("<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {} {}] /Resources << /Font << "
                  "/F1 5 0 R >> >> /Contents 4 0 R >>",
                  pt(pageW), pt(pageH)),
      fmt::format("<< /Length {} >>\nstream\n{}endstream", content.size(), content),
      "<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica >>",
  };
  std::string pdf = "%PDF-1.4\n";
  std::vector<size_t> offsets;
  for (size_t i = 0; i < objects.size(); ++i) {
    offsets.push_back(pdf.size());
    pdf += fmt::format("{} 0 obj\n{}\nendobj\n", i + 1, objects[i]);
  }
  const size_t xref = pdf.size();
  pdf += fmt::format("xref\n0 {}\n0000000000 65535 f \n", objects.size() + 1);
  for (size_t offset : offsets) pdf += fmt::format("{:010d} 00000 n \n", offset);
  pdf += fmt::format("trailer\n<< /Size {} /Root 1 0 R >>\nstartxref\n{}\n%%EOF\n",
                     objects.size() + 1, xref);
  return pdf;
}

void writePng(const BoardSheet& sheet, const std::string& caption, double dpi,
              const std::string& path) {
  const cv::Mat picture = rasterizeSheet(sheet, dpi / 25.4);
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw InputError({path, "", 0}, "OpenImageIO cannot create a PNG writer");
  OIIO::ImageSpec spec(picture.cols, picture.rows, 1, OIIO::TypeDesc::UINT8);
  // pHYs: what makes a viewer or `lp` print it at size.
  spec.attribute("XResolution", static_cast<float>(dpi));
  spec.attribute("YResolution", static_cast<float>(dpi));
  spec.attribute("ResolutionUnit", "inch");
  spec.attribute("ImageDescription", caption);
  const std::string temporary = path + ".partial.png";
  if (!out->open(temporary, spec) ||
      !out->write_image(OIIO::TypeDesc::UINT8, picture.data, OIIO::AutoStride, picture.step[0]) ||
      !out->close()) {
    std::filesystem::remove(temporary);
    throw InputError({path, "", 0}, "cannot write: " + out->geterror());
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) throw InputError({path, "", 0}, "cannot write: " + ec.message());
}

}  // namespace

void writeBoardSheet(const CalibrationBoard& board, const std::string& path, double dpi) {
  const BoardSheet sheet = boardSheet(board);
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".pdf") {
    const std::string caption =
        fmt::format("{}; sheet {:g} x {:g} mm", board.describe(), sheet.widthMm, sheet.heightMm);
    writeFileAtomically(path, boardPdf(sheet, caption));
    return;
  }
  if (extension == ".png") {
    if (!(dpi >= 72.0 && dpi <= 2400.0))
      throw InputError({"", "--dpi", 0}, fmt::format("must be 72..2400, got {}", dpi));
    const std::string caption =
        fmt::format("{}; sheet {:g} x {:g} mm at {:g} dpi: print at 100% (no fit to page)",
                    board.describe(), sheet.widthMm, sheet.heightMm, dpi);
    writePng(sheet, caption, dpi, path);
    return;
  }
  throw InputError({"", "--out", 0}, fmt::format("\"{}\": give a .png or a .pdf file", path));
}

}  // namespace parallax::cli
