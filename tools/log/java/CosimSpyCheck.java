// What lcm-spy does with the project's message types, without a display: lcm-spy finds a
// message's Java class by its LCM fingerprint in lcm.spy.LCMTypeDatabase (which scans the
// class path, as lcm-spy does at start) and decodes it with the class's byte[] constructor.
// This program does the same for every event of an LCM log and prints, per channel, the
// count, the type found and how many decoded; with --fields, the fields of the first decoded
// message of each channel (what lcm-spy's message view shows).
//
//   java -cp /usr/share/java/lcm.jar:build/java/cosimlcm.jar:build/java CosimSpyCheck LOG [--fields]
//   java -cp ... CosimSpyCheck --types      (the project's types lcm-spy would find)
//
// Built and run by launch/lcm-spy.sh --check LOG (docs/logs.md). Exit 0 when every message
// on a protocol channel decoded, 1 otherwise, 2 for bad arguments.
import java.io.EOFException;
import java.lang.reflect.Array;
import java.lang.reflect.Field;
import java.util.Map;
import java.util.TreeMap;

import lcm.logging.Log;
import lcm.spy.LCMTypeDatabase;

public class CosimSpyCheck {
    static final String[] TYPES = {"hello_t", "welcome_t", "solid_state_t", "fluid_state_t",
                                   "resend_t", "stop_t"};
    static final String[] SUFFIXES = {"HELLO", "WELCOME", "SOLID_STATE", "FLUID_STATE",
                                      "RESEND", "STOP"};

    static class Channel {
        long count, decoded;
        Map<String, Long> types = new TreeMap<>();
        String firstError;
        Object first;
    }

    static long fingerprint(byte[] d) {
        long v = 0;
        for (int i = 0; i < 8 && i < d.length; ++i) v = (v << 8) | (d[i] & 0xff);
        return v;
    }

    static String value(Object v) {
        if (v == null) return "null";
        if (v.getClass().isArray()) {
            int n = Array.getLength(v);
            StringBuilder b = new StringBuilder("[");
            for (int i = 0; i < n && i < 3; ++i) b.append(i > 0 ? ", " : "").append(value(Array.get(v, i)));
            if (n > 3) b.append(", ... (").append(n).append(")");
            return b.append("]").toString();
        }
        if (v instanceof String) return "\"" + v + "\"";
        return v.toString();
    }

    public static void main(String[] args) throws Exception {
        if (args.length < 1 || args.length > 2) {
            System.err.println("usage: CosimSpyCheck LOG [--fields] | --types");
            System.exit(2);
        }
        LCMTypeDatabase db = new LCMTypeDatabase();
        if (args[0].equals("--types")) {
            int found = 0;
            for (String t : TYPES) {
                Class<?> c = Class.forName("cosimlcm." + t);
                long fp = c.getField("LCM_FINGERPRINT").getLong(null);
                Class<?> byFp = db.getClassByFingerprint(fp);
                System.out.printf("cosimlcm.%-14s fingerprint 0x%016x  lcm-spy's type database: %s%n", t, fp,
                                  byFp == null ? "NOT FOUND" : byFp.getName());
                if (byFp == c) ++found;
            }
            System.out.println(found + " of " + TYPES.length + " types found by fingerprint");
            System.exit(found == TYPES.length ? 0 : 1);
        }
        boolean fields = args.length == 2 && args[1].equals("--fields");
        if (args.length == 2 && !fields) {
            System.err.println("CosimSpyCheck: unknown option " + args[1] + "; allowed: --fields");
            System.exit(2);
        }
        Log log;
        try {
            log = new Log(args[0], "r");
        } catch (java.io.IOException e) {
            System.err.println("CosimSpyCheck: " + args[0] + ": cannot open: " + e.getMessage());
            System.exit(2);
            return;
        }
        Map<String, Channel> channels = new TreeMap<>();
        long events = 0;
        while (true) {
            Log.Event e;
            try {
                e = log.readNext();
            } catch (EOFException eof) {
                break;
            }
            ++events;
            Channel ch = channels.computeIfAbsent(e.channel, k -> new Channel());
            ++ch.count;
            Class<?> c = db.getClassByFingerprint(fingerprint(e.data));
            String type = c == null ? String.format("unknown 0x%016x", fingerprint(e.data)) : c.getSimpleName();
            ch.types.merge(type, 1L, Long::sum);
            if (c == null) continue;
            try {
                Object o = c.getConstructor(byte[].class).newInstance((Object) e.data);
                ++ch.decoded;
                if (ch.first == null) ch.first = o;
            } catch (Exception ex) {
                Throwable cause = ex.getCause() != null ? ex.getCause() : ex;
                if (ch.firstError == null) ch.firstError = cause.toString();
            }
        }
        boolean ok = true;
        System.out.printf("%s: %d events; types found by fingerprint as lcm-spy finds them%n", args[0], events);
        System.out.printf("%-32s %8s %8s  %s%n", "channel", "count", "decoded", "types");
        for (Map.Entry<String, Channel> en : channels.entrySet()) {
            Channel ch = en.getValue();
            System.out.printf("%-32s %8d %8d  %s%n", en.getKey(), ch.count, ch.decoded, ch.types);
            if (ch.firstError != null) System.out.println("  first failure: " + ch.firstError);
            boolean protocol = false;
            for (String s : SUFFIXES) protocol |= en.getKey().endsWith(s);
            if (protocol && ch.decoded != ch.count) ok = false;
        }
        if (fields) {
            for (Map.Entry<String, Channel> en : channels.entrySet()) {
                if (en.getValue().first == null) continue;
                Object o = en.getValue().first;
                System.out.println();
                System.out.println(en.getKey() + ": " + o.getClass().getName() + " (first message)");
                for (Field f : o.getClass().getFields()) {
                    if (java.lang.reflect.Modifier.isStatic(f.getModifiers())) continue;
                    System.out.printf("  %-18s %s%n", f.getName(), value(f.get(o)));
                }
            }
        }
        System.exit(ok ? 0 : 1);
    }
}
