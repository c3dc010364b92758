/* Test plugin lacking detect/segment/destroy: the loader must name them. */
#include <stddef.h>
#include <stdint.h>

#define EXPORT __attribute__((visibility("default")))

EXPORT uint32_t sitepose_detector_abi_version(void) { return 1u; }
EXPORT void* sitepose_detector_create(const char* c, char* e, size_t n) {
  (void)c; (void)e; (void)n;
  return NULL;
}
