/* Test plugin (plain C) that crashes on a chosen frame, for crash isolation
 * (issue 20: sitepose-detector-host). Settings in the config text (for
 * siteposed: detector.model_config): "crash_at=N how=segv|abort|exit
 * log=PATH create_crash=1". detect() returns one "truck" box, instance 1,
 * the middle half of the image, and crashes when seq == N (segv: a write
 * through a null pointer; abort; exit: exit(7)); segment() paints that box.
 * With log=PATH every answered detect() appends "<pid> <seq>" to PATH, so
 * a test sees which process answered which frame. create_crash=1 crashes
 * in create(). */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "sitepose/detect/plugin_abi.h"

#define EXPORT __attribute__((visibility("default")))

struct sp_detector {
  long long crash_at;
  int how; /* 0 segv, 1 abort, 2 exit */
  char log[512];
};

static long long setting(const char* config, const char* key, long long fallback) {
  const char* at = config != NULL ? strstr(config, key) : NULL;
  if (at == NULL) return fallback;
  return strtoll(at + strlen(key), NULL, 10);
}

static void crash(int how) {
  if (how == 1) abort();
  if (how == 2) exit(7);
  volatile int* volatile nowhere = NULL;
  *nowhere = 1;
}

EXPORT uint32_t sitepose_detector_abi_version(void) { return SITEPOSE_DETECTOR_ABI_VERSION; }

EXPORT sp_detector* sitepose_detector_create(const char* config, char* err, size_t errlen) {
  (void)err;
  (void)errlen;
  if (setting(config, "create_crash=", 0) == 1) crash(0);
  sp_detector* h = (sp_detector*)calloc(1, sizeof(sp_detector));
  if (h == NULL) return NULL;
  h->crash_at = setting(config, "crash_at=", -1);
  const char* how = config != NULL ? strstr(config, "how=") : NULL;
  h->how = how == NULL ? 0 : strncmp(how + 4, "abort", 5) == 0 ? 1 : strncmp(how + 4, "exit", 4) == 0 ? 2 : 0;
  const char* log = config != NULL ? strstr(config, "log=") : NULL;
  if (log != NULL) {
    size_t n = strcspn(log + 4, " \"\n");
    if (n >= sizeof(h->log)) n = sizeof(h->log) - 1;
    memcpy(h->log, log + 4, n);
  }
  return h;
}

EXPORT uint32_t sitepose_detector_capabilities(const sp_detector* handle) {
  (void)handle;
  return SP_DETECTOR_CAP_SEGMENTATION | SP_DETECTOR_CAP_TRACKS_IDS;
}

EXPORT int sitepose_detector_detect(sp_detector* handle, const sp_image* left, const sp_image* right,
                                    int64_t t_ns, int64_t seq, sp_detection* out, int32_t capacity,
                                    int32_t* count, char* err, size_t errlen) {
  (void)right;
  (void)t_ns;
  (void)err;
  (void)errlen;
  if (seq == handle->crash_at) crash(handle->how);
  if (handle->log[0] != '\0') {
    FILE* f = fopen(handle->log, "a");
    if (f != NULL) {
      fprintf(f, "%d %lld\n", (int)getpid(), (long long)seq);
      fclose(f);
    }
  }
  *count = 1;
  if (capacity < 1) return 0;
  memset(&out[0], 0, sizeof(out[0]));
  strcpy(out[0].class_name, "truck");
  out[0].score = 0.9f;
  out[0].x = left->width / 4;
  out[0].y = left->height / 4;
  out[0].w = left->width / 2;
  out[0].h = left->height / 2;
  out[0].instance = 1;
  return 0;
}

EXPORT int sitepose_detector_segment(sp_detector* handle, const sp_image* left, const sp_image* right,
                                     int64_t t_ns, int64_t seq, const sp_detection* detections,
                                     int32_t n_detections, uint16_t* mask, int32_t mask_stride_px, char* err,
                                     size_t errlen) {
  (void)handle;
  (void)right;
  (void)t_ns;
  (void)seq;
  (void)err;
  (void)errlen;
  for (int32_t i = 0; i < n_detections; ++i) {
    const sp_detection* d = &detections[i];
    for (int32_t v = d->y; v < d->y + d->h && v < left->height; ++v) {
      for (int32_t u = d->x; u < d->x + d->w && u < left->width; ++u) {
        /* a checkerboard inside the box: a mask that is not just the box */
        if (((u + v) & 1) == 0) mask[(size_t)v * (size_t)mask_stride_px + (size_t)u] = d->instance;
      }
    }
  }
  return 0;
}

EXPORT void sitepose_detector_destroy(sp_detector* handle) { free(handle); }
