#pragma once
// The room the simulators of one cluster share (issue 23). Each rank of `mpirun parallaxd`
// starts a parallax-simhw for the modules its link reaches, but the modules stand in one room
// and one calibration camera sees the light of all of them. So each simulator writes what its
// modules show in pattern mode into the room folder (a file a module, named by its display
// index, replaced atomically before the frame is acknowledged), and a simulator's camera
// takes the modules that are not its own from there (RoomPhysics). Only a calibration
// photographs the screen: in playback mode nothing is written, and a simulator that leaves
// pattern mode removes its files. The ranks' simulators must share the folder's filesystem
// (one machine), which the simulated cluster of the tests is.

#include <memory>
#include <string>
#include <vector>

#include "hw/link/image.h"
#include "hw/simulator/camera_physics.h"

namespace parallax::hw {

class SimulatedHardware;

class SharedRoom {
 public:
  // `own[i]`: the display index of the simulator's module i. An empty folder: no room (the
  // other modules are dark to this simulator's camera).
  SharedRoom(std::string folder, std::vector<int> own);
  // After a module showed a new frame, or the mode changed (on the serving thread).
  void update(const SimulatedHardware& hardware);
  // What display module `module` shows, as its simulator wrote it; empty when nothing is
  // written (its simulator is not in pattern mode) or the file is not whole.
  Image read(int module) const;
  const std::vector<int>& own() const { return own_; }

 private:
  std::string pathOf(int module) const;
  void removeOwn();

  std::string folder_;
  std::vector<int> own_;
  std::vector<uint64_t> written_;  // per own module: the content hash in its file (0: none)
  bool pattern_ = false;
};

// The camera of one simulator in the room: its own modules' frames where they are, every other
// module's from the room, photographed by the whole display's physics.
class RoomPhysics final : public CameraPhysics {
 public:
  RoomPhysics(std::unique_ptr<CameraPhysics> display, int displayModules,
              std::shared_ptr<const SharedRoom> room);
  Image render(std::span<const Image* const> frames, int viewModule, int station,
               const CameraSettings& settings) const override;

 private:
  std::unique_ptr<CameraPhysics> display_;
  int displayModules_;
  std::shared_ptr<const SharedRoom> room_;
};

}  // namespace parallax::hw
