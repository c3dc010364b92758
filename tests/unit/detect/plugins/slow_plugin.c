/* Test plugin (plain C) that is slow or hangs on chosen frames, for the
 * detect stage's deadline (issue 20). Its settings come in detector.model_config,
 * inside the YAML the host passes: "slow_from=N slow_to=M sleep_ms=S" sleeps
 * S ms in detect() for frames N <= seq < M; S = -1 never returns. Otherwise
 * it returns at once with no detections. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "sitepose/detect/plugin_abi.h"

#define EXPORT __attribute__((visibility("default")))

struct sp_detector {
  long long slow_from;
  long long slow_to;
  long long sleep_ms;
};

static long long setting(const char* config, const char* key, long long fallback) {
  const char* at = config != NULL ? strstr(config, key) : NULL;
  if (at == NULL) return fallback;
  return strtoll(at + strlen(key), NULL, 10);
}

static void sleep_ms(long long ms) {
  struct timespec ts;
  ts.tv_sec = (time_t)(ms / 1000);
  ts.tv_nsec = (long)((ms % 1000) * 1000000);
  while (nanosleep(&ts, &ts) != 0) {
  }
}

EXPORT uint32_t sitepose_detector_abi_version(void) { return SITEPOSE_DETECTOR_ABI_VERSION; }

EXPORT sp_detector* sitepose_detector_create(const char* config, char* err, size_t errlen) {
  (void)err;
  (void)errlen;
  sp_detector* h = (sp_detector*)calloc(1, sizeof(sp_detector));
  if (h == NULL) return NULL;
  h->slow_from = setting(config, "slow_from=", -1);
  h->slow_to = setting(config, "slow_to=", -1);
  h->sleep_ms = setting(config, "sleep_ms=", 0);
  return h;
}

EXPORT uint32_t sitepose_detector_capabilities(const sp_detector* handle) {
  (void)handle;
  return 0u;
}

EXPORT int sitepose_detector_detect(sp_detector* handle, const sp_image* left, const sp_image* right,
                                    int64_t t_ns, int64_t seq, sp_detection* out, int32_t capacity,
                                    int32_t* count, char* err, size_t errlen) {
  (void)left;
  (void)right;
  (void)t_ns;
  (void)out;
  (void)capacity;
  (void)err;
  (void)errlen;
  if (seq >= handle->slow_from && seq < handle->slow_to) {
    if (handle->sleep_ms < 0) {
      for (;;) sleep_ms(1000); /* hangs: the host must not wait for it */
    }
    sleep_ms(handle->sleep_ms);
  }
  *count = 0;
  return 0;
}

EXPORT int sitepose_detector_segment(sp_detector* handle, const sp_image* left, const sp_image* right,
                                     int64_t t_ns, int64_t seq, const sp_detection* detections,
                                     int32_t n_detections, uint16_t* mask, int32_t mask_stride_px, char* err,
                                     size_t errlen) {
  (void)handle;
  (void)left;
  (void)right;
  (void)t_ns;
  (void)seq;
  (void)detections;
  (void)n_detections;
  (void)mask;
  (void)mask_stride_px;
  snprintf(err, errlen, "slow plugin cannot segment");
  return 1;
}

EXPORT void sitepose_detector_destroy(sp_detector* handle) { free(handle); }
