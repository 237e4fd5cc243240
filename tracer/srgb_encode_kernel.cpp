// Compiled once per instruction set by Highway's foreach_target, as shadow_ray_kernel.cpp is.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3  // SSSE3 without SSE4 (CPUs before 2008): one compile less
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/srgb_encode_kernel.cpp"
#include "tracer/srgb_encode_kernel.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstring>

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void EncodeSrgbChannels(const float* in, size_t n, const SrgbTable& table, std::uint8_t* out) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const hn::Rebind<std::uint8_t, decltype(d)> d8;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMaxLanes = HWY_MAX_BYTES / sizeof(float);
  const size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0f);
  const auto* words = reinterpret_cast<const std::int32_t*>(table.words);
  const auto lowBits = hn::Set(di, (1 << SrgbTable::kShift) - 1);
  const auto stepBits = hn::Set(di, (1 << 24) - 1), codeBits = hn::Set(di, 0xFF);
  // The code of 0, as the loop below finds it: a vector of zeros (black, where a module's rays
  // are masked: half its pixels, in runs) is stored without the gather.
  const auto code = [&](V c) {
    const auto bits = hn::BitCast(di, c);
    const auto word = hn::GatherIndex(di, words, hn::ShiftRight<SrgbTable::kShift>(bits));
    // A true mask is −1 as a vector: subtracting it adds one.
    const auto next = hn::Not(hn::Lt(hn::And(bits, lowBits), hn::And(word, stepBits)));
    return hn::DemoteTo(
        d8, hn::Sub(hn::And(hn::ShiftRight<24>(word), codeBits), hn::VecFromMask(di, next)));
  };
  const auto black = code(zero);

  for (size_t i = 0; i < n; i += lanes) {
    const size_t here = n - i < lanes ? n - i : lanes;
    V x;
    if (here == lanes) {
      x = hn::LoadU(d, in + i);
    } else {
      HWY_ALIGN float tail[kMaxLanes] = {};
      std::memcpy(tail, in + i, here * sizeof(float));
      x = hn::Load(d, tail);
    }
    if (here == lanes && hn::AllTrue(d, hn::Eq(x, zero))) {
      hn::StoreU(black, d8, out + i);
      continue;
    }
    // maxps(x, 0) then minps(·, 1): NaN and −inf to 0, +inf to 1, as srgb8FromLinear does
    // (and −0 to +0: Gt is false for it).
    V c = hn::IfThenElse(hn::Gt(x, zero), x, zero);
    c = hn::IfThenElse(hn::Lt(c, one), c, one);
    const auto bytes = code(c);
    if (here == lanes) {
      hn::StoreU(bytes, d8, out + i);
    } else {
      HWY_ALIGN std::uint8_t tail[kMaxLanes];
      hn::StoreU(bytes, d8, tail);
      std::memcpy(out + i, tail, here);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(EncodeSrgbChannels);

void encodeSrgbChannels(const float* in, size_t n, const SrgbTable& table, std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(EncodeSrgbChannels)(in, n, table, out);
}

}  // namespace parallax
#endif
