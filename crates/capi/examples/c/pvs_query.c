/*
 * pvs_query: the sightline C API end to end.
 *
 *   pvs_query FILE.pvs [X Y Z]...
 *
 * Opens FILE.pvs, prints its counts, cells and objects, then for each position (from the
 * arguments, or whitespace-separated from standard input when there are none) the cell that
 * holds it and the objects (and number of triangles) visible from there. Every error is
 * reported with sl_last_error(); everything is freed on every path (tests/c_program.rs runs
 * it under valgrind).
 *
 * Output, one record a line, numbers as printf %.9g (exact for floats):
 *   version V / cells N / objects N / triangles N / scene_hash HEX
 *   cell I center X Y Z axes 9 floats half_extents X Y Z
 *   object I name "ESCAPED" index N|- part N|- bounds MINX MINY MINZ MAXX MAXY MAXZ
 *   position X Y Z cell I objects K: ID... triangles T
 *   position X Y Z cell I objects none triangles T      (a version-1 file)
 *   position X Y Z outside                              (draw everything)
 * Names are printed byte by byte: '!'..'~' as they are, except '"' and '\', and every other
 * byte (space, NUL, UTF-8 beyond ASCII) as \xHH.
 *
 * Exit status: 0 on success, 1 when the library reports an error, 2 on bad usage.
 */

#include <stdio.h>
#include <stdlib.h>

#include "sightline.h"

/* Everything that must be freed, so that every exit path can free it. */
struct state {
    SlPvs *pvs;
    uint32_t *ids;
    size_t ids_capacity;
};

static void cleanup(struct state *s) {
    sl_pvs_close(s->pvs); /* NULL is a no-op */
    s->pvs = NULL;
    free(s->ids);
    s->ids = NULL;
    s->ids_capacity = 0;
}

/* Reports the library's last error and returns the exit status for it. */
static int library_error(struct state *s) {
    fprintf(stderr, "pvs_query: %s\n", sl_last_error());
    cleanup(s);
    return 1;
}

static void print_name(const SlObject *o) {
    putchar('"');
    for (size_t i = 0; i < o->name_len; i++) {
        unsigned char c = (unsigned char)o->name[i];
        if (c > ' ' && c <= '~' && c != '"' && c != '\\') {
            putchar(c);
        } else {
            printf("\\x%02x", c);
        }
    }
    putchar('"');
}

static void print_number_or_dash(uint32_t v) {
    if (v == SL_NONE) {
        printf("-");
    } else {
        printf("%u", (unsigned)v);
    }
}

/*
 * Fills s->ids with the objects visible from `cell`, growing the buffer as the reported count
 * asks. Returns the status of the last call (SL_STATUS_OK, or an error).
 */
static SlStatus visible_objects(struct state *s, uint32_t cell, size_t *count) {
    for (;;) {
        SlStatus status = sl_pvs_visible_objects(s->pvs, cell, s->ids, s->ids_capacity, count);
        if (status != SL_STATUS_INCOMPLETE) {
            return status;
        }
        uint32_t *grown = realloc(s->ids, *count * sizeof *grown);
        if (grown == NULL) {
            fprintf(stderr, "pvs_query: out of memory for %zu ids\n", *count);
            return SL_STATUS_FAILED;
        }
        s->ids = grown;
        s->ids_capacity = *count;
    }
}

/* Prints one position's line; `text` holds the three coordinates as given. */
static int query(struct state *s, char *const text[3]) {
    float position[3];
    for (int k = 0; k < 3; k++) {
        char *end = NULL;
        position[k] = strtof(text[k], &end);
        if (end == text[k] || *end != '\0') {
            fprintf(stderr, "pvs_query: not a number: '%s'\n", text[k]);
            cleanup(s);
            return 2;
        }
    }
    printf("position %s %s %s", text[0], text[1], text[2]);

    uint32_t cell = SL_NONE;
    SlStatus status = sl_pvs_cell_at(s->pvs, position, &cell);
    if (status == SL_STATUS_OUTSIDE) {
        printf(" outside\n");
        return 0;
    }
    if (status != SL_STATUS_OK) {
        printf("\n");
        return library_error(s);
    }
    printf(" cell %u", (unsigned)cell);

    size_t count = 0;
    status = visible_objects(s, cell, &count);
    if (status == SL_STATUS_NO_OBJECTS) {
        printf(" objects none");
    } else if (status == SL_STATUS_OK) {
        printf(" objects %zu:", count);
        for (size_t i = 0; i < count; i++) {
            printf(" %u", (unsigned)s->ids[i]);
        }
    } else {
        printf("\n");
        return library_error(s);
    }

    /* Capacity 0: only the count. */
    size_t triangles = 0;
    status = sl_pvs_visible_triangles(s->pvs, cell, NULL, 0, &triangles);
    if (status < 0) {
        printf("\n");
        return library_error(s);
    }
    printf(" triangles %zu\n", triangles);
    return 0;
}

int main(int argc, char **argv) {
    struct state s = {NULL, NULL, 0};
    if (argc < 2 || (argc - 2) % 3 != 0) {
        fprintf(stderr, "usage: %s FILE.pvs [X Y Z]...   (no positions: read them from stdin)\n",
                argv[0]);
        return 2;
    }

    s.pvs = sl_pvs_open(argv[1]);
    if (s.pvs == NULL) {
        return library_error(&s);
    }

    uint32_t cells = sl_pvs_cell_count(s.pvs);
    uint32_t objects = sl_pvs_object_count(s.pvs);
    printf("version %u\n", (unsigned)sl_pvs_version(s.pvs));
    printf("cells %u\n", (unsigned)cells);
    printf("objects %u\n", (unsigned)objects);
    printf("triangles %u\n", (unsigned)sl_pvs_triangle_count(s.pvs));
    printf("scene_hash %016llx\n", (unsigned long long)sl_pvs_scene_hash(s.pvs));

    for (uint32_t i = 0; i < cells; i++) {
        SlCell c;
        if (sl_pvs_cell(s.pvs, i, &c) != SL_STATUS_OK) {
            return library_error(&s);
        }
        printf("cell %u center %.9g %.9g %.9g axes", (unsigned)i, c.center[0], c.center[1],
               c.center[2]);
        for (int a = 0; a < 3; a++) {
            printf(" %.9g %.9g %.9g", c.axes[a][0], c.axes[a][1], c.axes[a][2]);
        }
        printf(" half_extents %.9g %.9g %.9g\n", c.half_extents[0], c.half_extents[1],
               c.half_extents[2]);
    }

    for (uint32_t i = 0; i < objects; i++) {
        SlObject o;
        if (sl_pvs_object(s.pvs, i, &o) != SL_STATUS_OK) {
            return library_error(&s);
        }
        printf("object %u name ", (unsigned)i);
        print_name(&o);
        printf(" index ");
        print_number_or_dash(o.index);
        printf(" part ");
        print_number_or_dash(o.part);
        printf(" bounds %.9g %.9g %.9g %.9g %.9g %.9g\n", o.bounds_min[0], o.bounds_min[1],
               o.bounds_min[2], o.bounds_max[0], o.bounds_max[1], o.bounds_max[2]);
    }

    if (argc > 2) {
        for (int i = 2; i + 2 < argc; i += 3) {
            int rc = query(&s, &argv[i]);
            if (rc != 0) {
                return rc;
            }
        }
    } else {
        char x[64], y[64], z[64];
        int n;
        while ((n = scanf("%63s %63s %63s", x, y, z)) == 3) {
            char *text[3] = {x, y, z};
            int rc = query(&s, text);
            if (rc != 0) {
                return rc;
            }
        }
        if (n != EOF) {
            fprintf(stderr, "pvs_query: standard input must hold X Y Z triples\n");
            cleanup(&s);
            return 2;
        }
    }

    cleanup(&s);
    return fflush(stdout) == 0 ? 0 : 1;
}
