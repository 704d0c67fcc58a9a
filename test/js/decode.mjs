// Decode MCAP bags with the libraries Foxglove opens files with, and print what they hold as JSON.
//
//   node decode.mjs BAG...
//
// Each bag is opened with @mcap/core's McapIndexedReader (summary, chunk and message indexes, CRCs
// checked), chunks decompressed with @foxglove/wasm-zstd / @foxglove/wasm-lz4, and every message of
// every channel decoded with @foxglove/rosmsg2-serialization from the channel's own schema text
// (parsed by @foxglove/rosmsg as ROS 2). Output, one JSON document on stdout:
//   {"<bag>": {"profile", "library", "topics": {"<topic>": {"type", "encoding", "schema_encoding",
//     "count", "trailing", "messages": [[log time ns (string), decoded message], ...]}}}}
// Typed arrays become lists, 64-bit integers numbers (strings beyond 2^53), non-finite floats
// the strings "NaN" / "Infinity" / "-Infinity". A problem ends the script with status 1 and
// says which.
import { open } from "node:fs/promises";

import { McapIndexedReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import lz4 from "@foxglove/wasm-lz4";
import * as zstd from "@foxglove/wasm-zstd";

const decompressHandlers = {
  zstd: (buffer, size) => zstd.decompress(buffer, Number(size)),
  lz4: (buffer, size) => lz4(buffer, Number(size)),
};

function fileReadable(handle) {
  return {
    size: async () => BigInt((await handle.stat()).size),
    read: async (offset, size) => {
      const buffer = new Uint8Array(Number(size));
      const { bytesRead } = await handle.read(buffer, 0, Number(size), Number(offset));
      if (bytesRead !== Number(size)) throw new Error(`short read at ${offset}`);
      return buffer;
    },
  };
}

function plain(value) {
  if (typeof value === "bigint") {
    return Number.isSafeInteger(Number(value)) ? Number(value) : value.toString();
  }
  if (typeof value === "number" && !Number.isFinite(value)) return String(value);
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

async function decodeBag(path) {
  const handle = await open(path, "r");
  try {
    const reader = await McapIndexedReader.Initialize({
      readable: fileReadable(handle), decompressHandlers });
    const readers = new Map();
    const topics = {};
    for (const [id, channel] of reader.channelsById) {
      const schema = reader.schemasById.get(channel.schemaId);
      if (schema === undefined) throw new Error(`${channel.topic}: no schema`);
      if (schema.encoding !== "ros2msg" || channel.messageEncoding !== "cdr") {
        throw new Error(`${channel.topic}: schema ${schema.encoding}, messages ` +
                        `${channel.messageEncoding} (not ros2msg / cdr)`);
      }
      const text = new TextDecoder().decode(schema.data);
      readers.set(id, new MessageReader(parse(text, { ros2: true })));
      topics[channel.topic] = { type: schema.name, encoding: channel.messageEncoding,
                                schema_encoding: schema.encoding, count: 0, trailing: 0,
                                messages: [] };
    }
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      const channel = reader.channelsById.get(message.channelId);
      const messageReader = readers.get(message.channelId);
      const entry = topics[channel.topic];
      const decoded = messageReader.readMessage(message.data);
      entry.count += 1;
      if (messageReader.lastReadHadTrailingBytes()) entry.trailing += 1;
      entry.messages.push([message.logTime.toString(), plain(decoded)]);
    }
    return { profile: reader.header.profile, library: reader.header.library, topics };
  } finally {
    await handle.close();
  }
}

await zstd.isLoaded;
await lz4.isLoaded;
const out = {};
for (const path of process.argv.slice(2)) {
  try {
    out[path] = await decodeBag(path);
  } catch (error) {
    process.stderr.write(`${path}: ${error.message}\n`);
    process.exit(1);
  }
}
process.stdout.write(JSON.stringify(out));
