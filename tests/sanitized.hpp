#pragma once
// Whether this test binary is built with AddressSanitizer (scripts/test-sanitizers): the tests
// whose runs the sanitizers make far slower skip or shorten themselves there (docs/robustness.md).

namespace rubref {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

}  // namespace rubref
