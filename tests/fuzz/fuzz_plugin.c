/* The plugin of the detector_abi harness (plain C, as a third party would
 * write one): it returns whatever bytes the harness hands it through the
 * config ("hex: <bytes in hex>"), so everything a plugin can put across the
 * C ABI reaches the host's validation.
 * Bytes: [0] capabilities, [1] detect's return code (non-zero: failure),
 * [2..5] the count it reports (int32, any value), then sp_detection records
 * copied into `out` (at most capacity), then uint16 mask pixels row by row
 * for segment(). */
#include <stdlib.h>
#include <string.h>

#include "sitepose/detect/plugin_abi.h"

#define EXPORT __attribute__((visibility("default")))

struct sp_detector {
  unsigned char* bytes;
  size_t size;
};

static int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

EXPORT uint32_t sitepose_detector_abi_version(void) { return SITEPOSE_DETECTOR_ABI_VERSION; }

EXPORT sp_detector* sitepose_detector_create(const char* config, char* err, size_t errlen) {
  const char* hex = config != NULL ? strstr(config, "hex: ") : NULL;
  sp_detector* h = (sp_detector*)calloc(1, sizeof(sp_detector));
  if (hex == NULL || h == NULL) {
    if (err != NULL && errlen > 0) strncpy(err, "expected hex: ...", errlen - 1);
    free(h);
    return NULL;
  }
  hex += 5;
  const size_t n = strlen(hex) / 2;
  h->bytes = (unsigned char*)malloc(n > 0 ? n : 1);
  for (size_t i = 0; i < n; ++i) {
    const int hi = hex_value(hex[2 * i]), lo = hex_value(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) break;
    h->bytes[h->size++] = (unsigned char)(hi * 16 + lo);
  }
  return h;
}

EXPORT uint32_t sitepose_detector_capabilities(const sp_detector* handle) {
  return handle->size > 0 ? handle->bytes[0] : 0u;
}

static size_t records_size(const sp_detector* handle, int32_t capacity) {
  const size_t available = handle->size > 6 ? handle->size - 6 : 0;
  const size_t n = available / sizeof(sp_detection);
  return (n < (size_t)capacity ? n : (size_t)capacity) * sizeof(sp_detection);
}

EXPORT int sitepose_detector_detect(sp_detector* handle, const sp_image* left, const sp_image* right,
                                    int64_t t_ns, int64_t seq, sp_detection* out, int32_t capacity,
                                    int32_t* count, char* err, size_t errlen) {
  (void)left;
  (void)right;
  (void)t_ns;
  (void)seq;
  if (handle->size < 6) return 0;
  if (handle->bytes[1] != 0) {
    /* An error text without its NUL: the host must not read past errlen. */
    memset(err, 'e', errlen);
    return handle->bytes[1];
  }
  memcpy(count, handle->bytes + 2, sizeof(int32_t));
  memcpy(out, handle->bytes + 6, records_size(handle, capacity));
  return 0;
}

EXPORT int sitepose_detector_segment(sp_detector* handle, const sp_image* left, const sp_image* right,
                                     int64_t t_ns, int64_t seq, const sp_detection* detections,
                                     int32_t n_detections, uint16_t* mask, int32_t mask_stride_px,
                                     char* err, size_t errlen) {
  (void)right;
  (void)t_ns;
  (void)seq;
  (void)detections;
  (void)n_detections;
  (void)err;
  (void)errlen;
  const size_t skip = 6 + records_size(handle, 256);
  size_t next = skip;
  for (int32_t v = 0; v < left->height; ++v) {
    for (int32_t u = 0; u < left->width && next + 1 < handle->size; ++u, next += 2) {
      memcpy(&mask[(size_t)v * (size_t)mask_stride_px + (size_t)u], handle->bytes + next, sizeof(uint16_t));
    }
  }
  return 0;
}

EXPORT void sitepose_detector_destroy(sp_detector* handle) {
  if (handle == NULL) return;
  free(handle->bytes);
  free(handle);
}
