#pragma once
// The picture sync code: a small band at the top of every pattern frame that says which frame
// it is, so a camera that delivers late (buffers, auto-processing, a module still showing the
// previous frame) is caught: a picture of another frame is retaken, never decoded as this one.
//
// Layout, in module rows from `firstRow` (the top of the screen as the nominal display has it,
// plus a margin: a module's picture overfills the screen): 2·kBits code cells of `cellRows`
// rows (Manchester: bit b of the code lights cell 2b when 1, cell 2b+1 when 0, so every coded
// frame lights exactly one cell of each pair, readable under any exposure), then one dark
// cell, then the patterns. The
// code is the frame's place in the session modulo kCodes, so up to kCodes − 1 frames of delay
// are seen. The white and black references show the band dark: their white − black contrast
// there is zero, so the decoder never decodes a band pixel, and the fiducials near the screen's
// edge stay the only bright spots of the black picture. The references are told apart by what
// they show (white_reference: a long bright area under a dark band; black: all dark).
//
// Torn pictures (modules change one at a time; a camera may expose between them): every coded
// and black picture is checked stripe by stripe (each module of the group shows in its own
// stripe, maybe a small share of the picture). A white reference cannot be checked alone, so
// the capture session (hw/camera/calibration_capture.cpp) takes it again after the set and
// compares the two (whitesDiffer), and ends each set on a coded frame, so that the next set's
// white reference never shows a module of this one as a stripe of its own. A second picture
// that misses stripes the first shows (compareWhiteStripes) was taken while the group's modules
// still changed, and is taken again: two such pictures alike prove nothing, since a camera may
// photograph one half-changed screen twice.
//
// Where the band lies in a picture is learned from the station's white reference, which shows
// it as a dark gap between the bright pattern area and the strip of screen above the band, per
// camera column through a module's stripe. The nominal display and the tape-measured station
// predict roughly where the screen is and how tall the band should look, which tells a white
// reference from a coded frame (whose band is partly lit).

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/display/display_model.h"

namespace parallax {

struct SyncCodeLayout {
  static constexpr int kBits = 3;
  static constexpr int kCodes = 1 << kBits;
  int firstRow = 0;
  int cellRows = 2;

  int codeCells() const { return 2 * kBits; }
  int bandRows() const { return cellRows * (codeCells() + 1); }  // the code cells and the gap
  int patternTop() const { return firstRow + bandRows(); }       // the first row under the band
};

// A cell is 1/48 of the rows the screen shows (a few camera pixels at the usual camera
// distance), at least two rows (one-row cells blur into each other); the band starts 3% of them
// under the lowest row at which a module's picture meets the screen's top edge. nullopt, with
// `why`, when the band would take more than 40% of the screen's rows (a display of tiny
// modules, as tests use).
std::optional<SyncCodeLayout> syncLayoutFor(const DisplayModel& nominal, std::string* why);

// What the nominal display and a camera at its tape-measured station predict, per camera column
// (0 where the screen is not seen): camera px per module row at the band, and the height of the
// pattern area under the band down to the screen's bottom edge.
struct SyncPrediction {
  std::vector<float> pxPerRow, patternPx;
};
SyncPrediction predictSync(const DisplayModel& nominal, const CameraIntrinsics& intrinsics,
                           const Eigen::Vector3d& tapeCentre, const SyncCodeLayout& layout);

// Draws the band into a module frame (CV_32F, linear, values in [0, 1]): `code` in 0..kCodes−1,
// or nullopt for the references' dark band.
void drawSyncCode(cv::Mat* frame, std::optional<int> code, const SyncCodeLayout& layout);

// Where the band lies in the camera pictures of one station and module group.
struct SyncGeometry {
  std::vector<int> columns;      // camera columns through a module's stripe
  std::vector<int> stripe;       // per column: its stripe (a run of neighbouring columns)
  std::vector<float> bandTop;    // per column: camera y of module row 0
  std::vector<float> whiteTop;   // per column: the white reference near the pattern's top edge
  std::vector<float> pxPerRow;   // per column: camera px per module row
  std::vector<float> patternPx;  // per column: the white pattern area's height
  float black = 0.0f;            // the white reference's dark level (pictureBlack)
};

// The dark level of a picture (linear light): its 2nd percentile. Light that reaches the dark
// parts of the screen as well as the lit ones (a room's lights, the camera's flare and black
// offset) lifts the band and the patterns' dark parts alike; the white reference's band and the
// black reference are judged above it, or a dim module's flanks read as lit (a photometric
// truth with modules at 83-92% of full brightness lost a third of its stripes so). A coded
// picture's cells are still read against zero: there, a flank whose cells the pedestal lifts
// reads as mixed and says nothing, where read above it, it could read a neighbour's band.
double pictureBlack(const cv::Mat& linear);

// From a picture that should be a white reference (linear light, CV_32F): the columns whose
// profile has a long bright run (at least half the predicted pattern area) under a dark band
// of the code's height (0.6–1.6 times the predicted), under the bright strip of the screen
// above the band. The band's height there gives the column's camera px per module row. Each
// run of such columns is a stripe (the middle of one module's light, where no neighbour's
// overlaps it); runs under three columns are left out. nullopt, with `why`, when the picture
// is not a white reference (a coded frame, dark). A torn white reference (a module still on
// the frame before) cannot be told from the picture alone, since the group's stripes overlap:
// whitesDiffer below catches it.
std::optional<SyncGeometry> syncGeometryFromWhite(const cv::Mat& linear,
                                                  const SyncCodeLayout& layout,
                                                  const SyncPrediction& prediction,
                                                  std::string* why);

// Why two pictures of the white reference (linear light) are not of the same screen, or
// nullopt when they are: compared at the same exposure (the second scaled to the first over
// the lit screen), after a little blur (the sensor's noise), no more than 0.2% of the pixels
// may differ by more than 15% of the brightest. One module still showing another frame in
// either changes a whole stripe, several percent of the picture.
std::optional<std::string> whitesDiffer(const cv::Mat& first, const cv::Mat& second);

// Two white references of one station and group, by the stripes they show. One taken while a
// module of the group still changed (its band still lit, or still dark) misses that module's
// stripe, and shows every other stripe where the whole one does (the same columns, the band
// within 2 px). (A module that should be dark and is still lit makes no stripe of its own:
// that tear shows only in whitesDiffer.)
struct WhiteStripes {
  bool firstMissesStripes = false;   // the second shows all of the first's stripes, and more
  bool secondMissesStripes = false;  // the reverse
};
WhiteStripes compareWhiteStripes(const SyncGeometry& first, const SyncGeometry& second);

struct SyncReading {
  std::optional<int> code;  // the code most columns read, when they agree
  double agreement = 0.0;   // fraction of the columns that read `code`
  double readable = 0.0;    // fraction of the columns with a readable code
  // The lit code cells over the white reference at the same place: the picture's exposure
  // relative to the white reference's (1 for a camera whose exposure is locked).
  double exposure = 0.0;
  // Over the columns whose cells are lit: the median of each column's weakest pair contrast,
  // (lit cell − unlit cell) / lit cell. Near 1 in a sharp picture; blur (a hand-held camera
  // that shook, a focus that slipped) runs the cells into each other (picture_quality.h).
  double contrast = 0.0;
  // When the columns agree but one stripe does not (a module still showing another frame):
  // which, and what it reads.
  std::string staleStripe;
  std::string describe() const;  // "code 3 (97% of columns)", "no code (12% readable)"
};

// Reads the code of a picture (linear light) of the same station and group. A code is
// reported when a quarter of the columns (at least 8) read one, 90% of those agree, and no
// stripe has a third of its columns (at least 3) showing another frame (another code, or a
// dark band): a module that has not changed yet shows in its own stripe only, which may be a
// small share of the columns. (Columns whose cells are lit alike, where two modules' bands
// meet, say nothing.)
SyncReading readSyncCode(const cv::Mat& linear, const SyncGeometry& geometry,
                         const SyncCodeLayout& layout);

// True when the picture shows the black reference: the band and the pattern area dark next to
// the white reference (above the band by under `fraction` of it): at most 10% of the columns
// lit, and under a third of any stripe's (a column is lit when most of its pattern area is:
// fiducials and glints are spots).
bool looksBlack(const cv::Mat& linear, const SyncGeometry& geometry, const SyncCodeLayout& layout,
                const SyncPrediction& prediction, double fraction = 0.3);

}  // namespace parallax
