/* Test plugin claiming a future ABI version: the loader must refuse it. */
#include <stddef.h>
#include <stdint.h>

#define EXPORT __attribute__((visibility("default")))

EXPORT uint32_t sitepose_detector_abi_version(void) { return 99u; }
EXPORT void* sitepose_detector_create(const char* c, char* e, size_t n) {
  (void)c; (void)e; (void)n;
  return NULL;
}
EXPORT uint32_t sitepose_detector_capabilities(const void* h) { (void)h; return 0u; }
EXPORT int sitepose_detector_detect(void) { return 1; }
EXPORT int sitepose_detector_segment(void) { return 1; }
EXPORT void sitepose_detector_destroy(void* h) { (void)h; }
