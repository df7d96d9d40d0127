// Cooperative cancellation. Every long loop (decoding, tracking, BA iterations through a
// Ceres IterationCallback, alignment) polls a token so that cancel takes effect within a
// second without killing threads. Tokens are shared: the job owns the source, workers hold
// copies.
#pragma once

#include <atomic>
#include <memory>

#include "engine/core/error.h"

namespace glam {

class CancellationToken {
 public:
  CancellationToken() : flag_(std::make_shared<std::atomic<bool>>(false)) {}

  void Cancel() const { flag_->store(true, std::memory_order_relaxed); }
  bool IsCancelled() const { return flag_->load(std::memory_order_relaxed); }
  // Throws glam::Cancelled when cancelled; convenient at loop heads.
  void ThrowIfCancelled() const {
    if (IsCancelled()) throw Cancelled();
  }

 private:
  std::shared_ptr<std::atomic<bool>> flag_;
};

}  // namespace glam
