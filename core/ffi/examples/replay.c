/* Plays a golden model's replays through the Sinew C API and prints every frame's hash in the
 * format of tests/data/NAME.hashes; exits non-zero if a frame differs from its recording or a
 * call fails.
 *
 *   replay DATA_DIR NAME     e.g. replay tests/data aim-ict
 *
 * NAME.sinew is the model: an AIM actor is played from NAME.f32/q16/fast.replay.sinew, an S2D
 * decoder from NAME.replay.sinew. Build and run: core/ffi/run-example.sh (docs/C-API.md). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sinew.h"

/* Reads a whole file into a malloc'd buffer, aligned for the library (malloc aligns to at least
 * 8 bytes); the handles borrow it, so it is freed only after them. */
static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open\n", path);
        return NULL;
    }
    uint8_t *bytes = NULL;
    long size = -1;
    if (fseek(f, 0, SEEK_END) == 0) {
        size = ftell(f);
    }
    if (size >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        bytes = malloc(size > 0 ? (size_t)size : 1);
        if (bytes != NULL && fread(bytes, 1, (size_t)size, f) != (size_t)size) {
            free(bytes);
            bytes = NULL;
        }
    }
    fclose(f);
    if (bytes == NULL) {
        fprintf(stderr, "%s: cannot read\n", path);
        return NULL;
    }
    *len = (size_t)size;
    return bytes;
}

/* Prints a failed call's message; returns 1 on failure, 0 on success. */
static int failed(SinewStatus status, const SinewError *err, const char *what) {
    if (status == SINEW_STATUS_OK) {
        return 0;
    }
    fprintf(stderr, "%s: %s (status %d)\n", what, err->message, (int)status);
    return 1;
}

static const char *MODE_NAMES[] = {"f32", "q16", "fast"};

/* A NaN in the head is refused in every mode, not guessed into a rotation: the status says so
 * even without an error record. Returns 1 if it is not refused. */
static int refuses_nan(const SinewModel *model, const SinewModelInfo *info, const char *what) {
    float head[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0}, jaw[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0};
    head[3] = strtof("nan", NULL);
    float *weights = calloc(info->shape_count + 1, sizeof(float));
    float *scratch = calloc(info->scratch_floats, sizeof(float));
    int bad = weights == NULL || scratch == NULL;
    for (uint32_t m = 0; m < 3 && !bad; m++) {
        uint64_t hash = 0;
        SinewStatus status = sinew_aim_frame_hash(model, m, head, jaw, weights, info->shape_count,
                                                  scratch, info->scratch_floats, &hash, NULL);
        if (status != SINEW_STATUS_INVALID_INPUT) {
            fprintf(stderr, "%s: a NaN head in mode %s gave \"%s\", not a refusal\n", what,
                    MODE_NAMES[m], sinew_status_string((uint32_t)status));
            bad = 1;
        }
    }
    free(weights);
    free(scratch);
    return bad;
}

/* Plays one replay file against an open model, printing "LABEL FRAME HASH" per frame. Returns the
 * number of differing frames, or -1 when something fails. */
static int play(const SinewModel *model, const SinewModelInfo *info, const char *path,
                const char *label) {
    SinewError err;
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return -1;
    }
    int bad = -1;
    SinewReplay *replay = NULL;
    SinewReplayInfo rinfo;
    float *scratch = calloc(info->scratch_floats, sizeof(float));
    float *weights = calloc(info->shape_count + 1, sizeof(float));
    float *input = calloc(info->input_len + 1, sizeof(float));
    float *neutral = NULL;
    float *vertices = calloc(3 * info->vertex_count, sizeof(float));
    if (scratch == NULL || weights == NULL || input == NULL || vertices == NULL) {
        fprintf(stderr, "%s: out of memory\n", path);
        goto done;
    }
    if (failed(sinew_replay_open(bytes, len, &replay, &err), &err, path) ||
        failed(sinew_replay_info(replay, &rinfo, &err), &err, path) ||
        failed(sinew_replay_check_model(replay, model, &err), &err, path)) {
        goto done;
    }
    if (rinfo.neutral_len > 0) {
        neutral = calloc(rinfo.neutral_len, sizeof(float));
        if (neutral == NULL ||
            failed(sinew_replay_s2d_neutral(replay, neutral, rinfo.neutral_len, &err), &err, path)) {
            goto done;
        }
    }
    bad = 0;
    for (size_t f = 0; f < rinfo.frame_count; f++) {
        uint64_t expected = 0, hash = 0;
        SinewStatus status;
        if (rinfo.kind == SINEW_KIND_AIM) {
            float head[9], jaw[9];
            status = sinew_replay_aim_frame(replay, f, head, jaw, weights, rinfo.shape_count,
                                            &expected, &err);
            if (status == SINEW_STATUS_OK) {
                status = sinew_aim_frame_hash(model, (uint32_t)rinfo.mode, head, jaw, weights,
                                              info->shape_count, scratch, info->scratch_floats,
                                              &hash, &err);
            }
        } else {
            status = sinew_replay_s2d_frame(replay, f, input, rinfo.input_len, &expected, &err);
            if (status == SINEW_STATUS_OK) {
                status = sinew_s2d_decode(model, input, info->input_len, neutral,
                                          rinfo.neutral_len, scratch, info->scratch_floats,
                                          vertices, 3 * info->vertex_count, &hash, &err);
            }
        }
        if (failed(status, &err, path)) {
            bad = -1;
            goto done;
        }
        printf("%s %zu %016llx\n", label, f, (unsigned long long)hash);
        if (hash != expected) {
            fprintf(stderr, "%s: frame %zu is %016llx, recorded %016llx\n", path, f,
                    (unsigned long long)hash, (unsigned long long)expected);
            bad++;
        }
    }
done:
    sinew_replay_free(replay);
    free(bytes);
    free(scratch);
    free(weights);
    free(input);
    free(neutral);
    free(vertices);
    return bad;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: %s DATA_DIR NAME (e.g. tests/data aim-ict)\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1], *name = argv[2];
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.sinew", dir, name);
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return 1;
    }
    SinewError err;
    SinewModel *model = NULL;
    SinewModelInfo info;
    if (failed(sinew_model_open(bytes, len, &model, &err), &err, path) ||
        failed(sinew_model_info(model, &info, &err), &err, path)) {
        sinew_model_free(model);
        free(bytes);
        return 1;
    }
    int bad = 0;
    if (info.kind == SINEW_KIND_AIM) {
        printf("# %s.sinew: %zu vertices, %zu shapes; per mode and frame: f32/fast hash positions "
               "then normals, q16 the positions' raw bits\n",
               name, info.vertex_count, info.shape_count);
        for (int m = 0; m < 3 && bad >= 0; m++) {
            snprintf(path, sizeof path, "%s/%s.%s.replay.sinew", dir, name, MODE_NAMES[m]);
            int r = play(model, &info, path, MODE_NAMES[m]);
            bad = r < 0 ? r : bad + r;
        }
        if (bad >= 0 && refuses_nan(model, &info, name)) {
            bad = -1;
        }
    } else {
        printf("# %s.sinew: %zu vertices, %zu inputs, %zu scratch values; per frame: the decoded "
               "vertices (f32 bits), decoded onto the replay's neutral\n",
               name, info.vertex_count, info.input_len, info.scratch_floats);
        snprintf(path, sizeof path, "%s/%s.replay.sinew", dir, name);
        bad = play(model, &info, path, "s2d");
    }
    sinew_model_free(model);
    free(bytes);
    if (bad != 0) {
        fprintf(stderr, "%s: %s\n", name, bad < 0 ? "failed" : "frames differ from the recording");
        return 1;
    }
    return 0;
}
