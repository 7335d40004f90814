#include "brdf/exr.h"

#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <openexr.h>

/* The Core library reports details (which system call failed, which
 * attribute is wrong) through a callback rather than the return code. The
 * context's user_data belongs to the default file stream, so the last
 * message is kept per thread here and folded into our one-line error. */
static _Thread_local char exr_last_msg[256];

static void exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_last_msg, sizeof exr_last_msg, "%s",
             msg ? msg : exr_get_default_error_message(code));
}

static int exr_fail(struct gonio_err *err, int code, const char *path, const char *what,
                    exr_result_t rv)
{
    const char *detail = exr_last_msg[0] ? exr_last_msg : exr_get_default_error_message(rv);
    return gonio_err_set(err, code, "%s: %s: %s (%s)", path, what, detail,
                         exr_get_error_code_as_string(rv));
}

/* Interleaved offset of an RGB channel by name, -1 for any other channel. */
static int rgb_offset(const char *name)
{
    if (!strcmp(name, "R"))
        return 0;
    if (!strcmp(name, "G"))
        return 1;
    if (!strcmp(name, "B"))
        return 2;
    return -1;
}

static exr_context_initializer_t exr_init(void)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    exr_last_msg[0] = '\0';
    return init;
}

static int write_chunks(exr_context_t ctxt, int part, int width, int height, const float *rgb,
                        const char *path, struct gonio_err *err)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctxt, part, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1)
        return exr_fail(err, GONIO_EBADDATA, path, "scanlines per chunk", rv);

    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int first = 1, ret = 0;
    for (int y = 0; y < height && ret == 0; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctxt, part, y, &cinfo);
        if (rv == EXR_ERR_SUCCESS)
            rv = first ? exr_encoding_initialize(ctxt, part, &cinfo, &enc)
                       : exr_encoding_update(ctxt, part, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS) {
            ret = exr_fail(err, GONIO_EBADDATA, path, "chunk setup", rv);
            break;
        }
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            int off = rgb_offset(ch->channel_name);
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = 3 * (int32_t)sizeof(float) * width;
            ch->encode_from_ptr =
                (const uint8_t *)(rgb + ((size_t)cinfo.start_y * (size_t)width) * 3 + off);
        }
        if (first) {
            rv = exr_encoding_choose_default_routines(ctxt, part, &enc);
            first = 0;
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctxt, part, &enc);
        if (rv != EXR_ERR_SUCCESS)
            ret = exr_fail(err, GONIO_EBADDATA, path, "encoding scanlines", rv);
    }
    exr_encoding_destroy(ctxt, &enc);
    return ret;
}

int brdf_exr_write_rgb(const char *path, int width, int height, const float *rgb,
                       struct gonio_err *err)
{
    if (!path || !*path)
        return gonio_err_set(err, EINVAL, "exr: empty output path");
    if (width < 1 || height < 1 || width > INT_MAX / 3 / 4 / height)
        return gonio_err_set(err, EINVAL,
                             "%s: image size %dx%d: must be at least 1x1 (and fit in memory)", path,
                             width, height);
    if (!rgb)
        return gonio_err_set(err, EINVAL, "%s: no pixel data", path);

    exr_context_initializer_t init = exr_init();
    exr_context_t ctxt = NULL;
    exr_result_t rv = exr_start_write(&ctxt, path, EXR_INTERMEDIATE_TEMP_FILE, &init);
    if (rv != EXR_ERR_SUCCESS) {
        int ret = exr_fail(err, rv == EXR_ERR_FILE_ACCESS ? EIO : GONIO_EBADDATA, path,
                           "cannot create", rv);
        if (ctxt)
            exr_finish(&ctxt);
        return ret;
    }

    int part = 0, ret = 0;
    rv = exr_add_part(ctxt, "rgb", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctxt, part, width, height, EXR_COMPRESSION_ZIP);
    static const char *const names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3 && rv == EXR_ERR_SUCCESS; c++)
        rv = exr_add_channel(ctxt, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC,
                             1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctxt);
    if (rv != EXR_ERR_SUCCESS)
        ret = exr_fail(err, GONIO_EBADDATA, path, "header", rv);
    else
        ret = write_chunks(ctxt, part, width, height, rgb, path, err);

    /* With every chunk written exr_finish writes the offset table and renames
     * the temporary file into place; a context left short of chunks is
     * discarded with its temporary file. */
    rv = exr_finish(&ctxt);
    if (ret == 0 && rv != EXR_ERR_SUCCESS)
        ret = exr_fail(err, GONIO_EBADDATA, path, "finishing", rv);
    return ret;
}

static int read_chunks(exr_const_context_t ctxt, const exr_attr_box2i_t *dw, int width,
                       int height, float *out, const char *path, struct gonio_err *err)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1)
        return exr_fail(err, GONIO_EBADDATA, path, "scanlines per chunk", rv);

    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int first = 1, ret = 0;
    for (int y = dw->min.y; y <= dw->max.y; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_read_scanline_chunk_info(ctxt, 0, y, &cinfo);
        if (rv == EXR_ERR_SUCCESS)
            rv = first ? exr_decoding_initialize(ctxt, 0, &cinfo, &dec)
                       : exr_decoding_update(ctxt, 0, &cinfo, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            ret = exr_fail(err, GONIO_EBADDATA, path, "reading chunk", rv);
            break;
        }
        int row = cinfo.start_y - dw->min.y;
        if (row < 0 || row + cinfo.height > height) {
            ret = gonio_err_set(err, GONIO_EBADDATA, "%s: chunk at y=%d outside the data window",
                                path, cinfo.start_y);
            break;
        }
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int off = rgb_offset(ch->channel_name);
            if (off < 0) {
                ch->decode_to_ptr = NULL; /* skipped by the decoder */
                continue;
            }
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = 3 * (int32_t)sizeof(float) * width;
            ch->decode_to_ptr = (uint8_t *)(out + ((size_t)row * (size_t)width) * 3 + off);
        }
        if (first) {
            rv = exr_decoding_choose_default_routines(ctxt, 0, &dec);
            first = 0;
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_decoding_run(ctxt, 0, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            ret = exr_fail(err, GONIO_EBADDATA, path, "decoding scanlines", rv);
            break;
        }
    }
    exr_decoding_destroy(ctxt, &dec);
    return ret;
}

int brdf_exr_read_rgb(const char *path, int *width, int *height, float **rgb,
                      struct gonio_err *err)
{
    if (!path || !*path || !width || !height || !rgb)
        return gonio_err_set(err, EINVAL, "exr: missing path or output argument");
    *rgb = NULL;
    *width = *height = 0;

    exr_context_initializer_t init = exr_init();
    exr_context_t ctxt = NULL;
    exr_result_t rv = exr_start_read(&ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        int ret = exr_fail(err, rv == EXR_ERR_FILE_ACCESS ? GONIO_ENOTFOUND : GONIO_EBADDATA,
                           path, "cannot open", rv);
        if (ctxt)
            exr_finish(&ctxt);
        return ret;
    }

    int ret = 0;
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    if (exr_get_storage(ctxt, 0, &storage) != EXR_ERR_SUCCESS || storage != EXR_STORAGE_SCANLINE) {
        ret = gonio_err_set(err, GONIO_EBADDATA, "%s: part 0: only scanline images are read", path);
        goto done;
    }
    rv = exr_get_data_window(ctxt, 0, &dw);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctxt, 0, &chl);
    if (rv != EXR_ERR_SUCCESS) {
        ret = exr_fail(err, GONIO_EBADDATA, path, "header", rv);
        goto done;
    }
    int found = 0;
    for (int c = 0; c < chl->num_channels; c++) {
        int off = rgb_offset(chl->entries[c].name.str);
        if (off < 0)
            continue;
        if (chl->entries[c].x_sampling != 1 || chl->entries[c].y_sampling != 1) {
            ret = gonio_err_set(err, GONIO_EBADDATA,
                                "%s: channel %s: subsampled channels are not supported", path,
                                chl->entries[c].name.str);
            goto done;
        }
        found |= 1 << off;
    }
    if (found != 7) {
        ret = gonio_err_set(err, GONIO_EBADDATA, "%s: channels: need R, G and B", path);
        goto done;
    }
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w < 1 || h < 1 || w > INT_MAX / 12 || h > INT_MAX / 12 / w) {
        ret = gonio_err_set(err, GONIO_EBADDATA, "%s: data window %lldx%lld: unusable size", path,
                            (long long)w, (long long)h);
        goto done;
    }
    float *out = calloc((size_t)(w * h * 3), sizeof *out);
    if (!out) {
        ret = gonio_err_set(err, ENOMEM, "%s: out of memory for %lldx%lld pixels", path,
                            (long long)w, (long long)h);
        goto done;
    }
    ret = read_chunks(ctxt, &dw, (int)w, (int)h, out, path, err);
    if (ret == 0) {
        *rgb = out;
        *width = (int)w;
        *height = (int)h;
    } else {
        free(out);
    }
done:
    exr_finish(&ctxt);
    return ret;
}
