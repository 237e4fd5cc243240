#include "daemon/parallaxd/render_while_sending.h"

#include <tbb/concurrent_queue.h>

#include <memory>
#include <thread>
#include <utility>

namespace parallax::daemon {

DisplayFrame renderWhileSending(const std::function<DisplayFrame(const ModuleDone&)>& render,
                                const ModuleDone& send, std::exception_ptr* sendError) {
  struct Done {
    size_t module = 0;
    std::shared_ptr<const hw::Image> image;  // null: the render is over
  };
  tbb::concurrent_bounded_queue<Done> done;
  *sendError = nullptr;
  // Mostly waiting on the link, so a thread of its own rather than a TBB task: the render keeps
  // every core.
  std::thread sender([&] {
    for (Done d;;) {
      done.pop(d);
      if (!d.image) return;
      if (*sendError) continue;
      try {
        send(d.module, std::move(d.image));
      } catch (...) {
        *sendError = std::current_exception();
      }
    }
  });
  DisplayFrame frame;
  std::exception_ptr renderError;
  try {
    frame = render([&](size_t module, std::shared_ptr<const hw::Image> image) {
      done.push({module, std::move(image)});
    });
  } catch (...) {
    renderError = std::current_exception();
  }
  done.push({});
  sender.join();
  if (renderError) std::rethrow_exception(renderError);
  return frame;
}

}  // namespace parallax::daemon
