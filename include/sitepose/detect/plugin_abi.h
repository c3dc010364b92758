/* sitepose detector plugin ABI, version 1 (plain C, stable).
 *
 * A detector plugin is a shared library exporting the functions declared
 * below with C linkage. sitepose loads it with dlopen(RTLD_NOW | RTLD_LOCAL),
 * so a detector built with any toolkit can be dropped in without rebuilding
 * sitepose. The built-in detectors (labels, stereo-geometric, opencv-dnn)
 * are plugins of this ABI too.
 *
 * Versioning: sitepose_detector_abi_version() must return exactly
 * SITEPOSE_DETECTOR_ABI_VERSION of the header the plugin was built with; the
 * loader refuses any other value. Any change to a struct layout or a
 * function signature below bumps the version.
 *
 * Images: 8-bit single-channel, rectified, row-major; `stride_bytes` >=
 * width. Left and right have the same size. Pixel coordinates are in the
 * LEFT image: x right, y down, origin at the top-left pixel corner.
 *
 * Threads and ownership: the host calls one handle from one thread at a time
 * (different handles may run concurrently). Image buffers and output arrays
 * are owned by the host and valid only during the call; the plugin must not
 * keep pointers to them. The handle is owned by the plugin from create()
 * until destroy(). No C++ exception may leave any of these functions.
 *
 * Errors: functions returning int return 0 on success, non-zero on failure,
 * and then write a NUL-terminated message (truncated to errlen bytes) into
 * `err`. create() returns NULL on failure. The host treats a failed call as
 * "no result for this frame" and counts it.
 *
 * Output is validated by the host, never trusted: boxes are clipped to the
 * image (dropped when nothing is left), detections with a non-finite or
 * negative score, instance 0 or an unterminated class name are dropped and
 * counted; *count beyond `capacity` counts as dropped.
 */
#ifndef SITEPOSE_DETECT_PLUGIN_ABI_H_
#define SITEPOSE_DETECT_PLUGIN_ABI_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SITEPOSE_DETECTOR_ABI_VERSION 1

/* Capability bits returned by sitepose_detector_capabilities(). */
#define SP_DETECTOR_CAP_SEGMENTATION 1u /* segment() writes pixel masks */
#define SP_DETECTOR_CAP_TRACKS_IDS 2u   /* instance ids are stable across frames */

#define SP_CLASS_NAME_LEN 32 /* bytes, NUL included */

typedef struct sp_image {
  int32_t width;
  int32_t height;
  int32_t stride_bytes;
  const uint8_t* data; /* CV_8UC1 */
} sp_image;

typedef struct sp_detection {
  char class_name[SP_CLASS_NAME_LEN]; /* NUL-terminated, e.g. "truck" */
  float score;                        /* confidence in [0, 1] */
  int32_t x, y, w, h;                 /* box in left-image pixels */
  uint16_t instance;                  /* > 0; stable across frames if the plugin tracks */
} sp_detection;

typedef struct sp_detector sp_detector; /* opaque, plugin-defined */

/* Returns SITEPOSE_DETECTOR_ABI_VERSION. */
typedef uint32_t (*sp_abi_version_fn)(void);

/* `config` is a YAML document (a flow or block mapping; JSON is valid YAML)
 * with the plugin's options; see each plugin's documentation. */
typedef sp_detector* (*sp_create_fn)(const char* config, char* err, size_t errlen);

/* Bitwise OR of SP_DETECTOR_CAP_* for this handle. */
typedef uint32_t (*sp_capabilities_fn)(const sp_detector* handle);

/* Detects objects in a stereo pair. `seq` is the frame index in its source,
 * `t_ns` the left capture time. Writes at most `capacity` detections to
 * `out` and the number it found to *count (which may exceed capacity: the
 * surplus is lost and counted by the host). */
typedef int (*sp_detect_fn)(sp_detector* handle, const sp_image* left, const sp_image* right,
                            int64_t t_ns, int64_t seq, sp_detection* out, int32_t capacity,
                            int32_t* count, char* err, size_t errlen);

/* Pixel instance masks for the given detections (those of detect() for the
 * same frame, already validated by the host). `mask` is a zeroed
 * left-image-sized uint16 buffer with `mask_stride_px` elements per row; the
 * plugin writes a detection's instance id into its object's pixels. Pixels
 * outside a detection's box, or with an id of no detection, are cleared by
 * the host. Only called when SP_DETECTOR_CAP_SEGMENTATION is set. */
typedef int (*sp_segment_fn)(sp_detector* handle, const sp_image* left, const sp_image* right,
                             int64_t t_ns, int64_t seq, const sp_detection* detections,
                             int32_t n_detections, uint16_t* mask, int32_t mask_stride_px,
                             char* err, size_t errlen);

typedef void (*sp_destroy_fn)(sp_detector* handle);

/* Exported symbol names (what the loader dlsym()s). */
#define SP_SYMBOL_ABI_VERSION "sitepose_detector_abi_version"
#define SP_SYMBOL_CREATE "sitepose_detector_create"
#define SP_SYMBOL_CAPABILITIES "sitepose_detector_capabilities"
#define SP_SYMBOL_DETECT "sitepose_detector_detect"
#define SP_SYMBOL_SEGMENT "sitepose_detector_segment"
#define SP_SYMBOL_DESTROY "sitepose_detector_destroy"

/* Prototypes a plugin implements (with default visibility). */
uint32_t sitepose_detector_abi_version(void);
sp_detector* sitepose_detector_create(const char* config, char* err, size_t errlen);
uint32_t sitepose_detector_capabilities(const sp_detector* handle);
int sitepose_detector_detect(sp_detector* handle, const sp_image* left, const sp_image* right,
                             int64_t t_ns, int64_t seq, sp_detection* out, int32_t capacity,
                             int32_t* count, char* err, size_t errlen);
int sitepose_detector_segment(sp_detector* handle, const sp_image* left, const sp_image* right,
                              int64_t t_ns, int64_t seq, const sp_detection* detections,
                              int32_t n_detections, uint16_t* mask, int32_t mask_stride_px,
                              char* err, size_t errlen);
void sitepose_detector_destroy(sp_detector* handle);

#ifdef __cplusplus
}
#endif

#endif /* SITEPOSE_DETECT_PLUGIN_ABI_H_ */
