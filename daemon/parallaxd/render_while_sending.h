#pragma once
// A display frame rendered while its images go out: a sender thread hands each module's image
// to the link as soon as that module is done, while the calling thread and TBB's workers render
// the rest. The link's work (content hashes, CRCs, the socket, waiting for the modules to take
// the bytes) then overlaps the render instead of following it. The link is the sender's alone
// for the call: the caller renders until every module is done and touches the link again only
// after the sender has finished. A module holds what it is sent until the frame is presented,
// so a render that fails halfway shows nothing of itself: the conductor does not present it.

#include <exception>
#include <functional>

#include "daemon/parallaxd/module_renderer.h"

namespace parallax::daemon {

// `render` renders the frame on this thread, calling the ModuleDone it is given for every
// module (on the workers); `send` is called with each module and image, in the order they
// finish, one at a time on the sender thread, while the others render; every call has returned
// when this does. Returns what `render` returned, or throws what it threw (after what it
// finished was sent). An exception from `send` stops the sending (the rest of the frame still
// renders) and is kept in `sendError`.
DisplayFrame renderWhileSending(const std::function<DisplayFrame(const ModuleDone&)>& render,
                                const ModuleDone& send, std::exception_ptr* sendError);

}  // namespace parallax::daemon
