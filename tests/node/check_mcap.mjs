// An independent reader of cartlab run files: the TypeScript @mcap/core (what Foxglove uses),
// with fzstd for zstd chunks. Reads FILE twice, with the indexed reader (summary, chunk and
// message indexes) and the stream reader (record by record), CRCs validated by both, parses
// every message as JSON and checks the fields its channel's JSON Schema requires. Prints one
// JSON object to stdout for the Python test to compare with what cartlab itself reads.
//
//   node check_mcap.mjs FILE
import { readFile } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { decompress } from "fzstd";

const decompressHandlers = {
  zstd: (buffer, size) => decompress(buffer, new Uint8Array(Number(size))),
};

function bufferReadable(bytes) {
  return {
    size: async () => BigInt(bytes.byteLength),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
}

function checkRequired(schema, message, where) {
  for (const key of schema.required ?? []) {
    if (!(key in message)) throw new Error(`${where}: required field ${key} missing`);
  }
}

async function indexed(bytes) {
  const reader = await McapIndexedReader.Initialize({ readable: bufferReadable(bytes), decompressHandlers });
  const decoder = new TextDecoder();
  const schemas = new Map();
  for (const [id, schema] of reader.schemasById) {
    schemas.set(id, { name: schema.name, encoding: schema.encoding, body: JSON.parse(decoder.decode(schema.data)) });
  }
  const topics = {};
  for (const channel of reader.channelsById.values()) {
    const schema = schemas.get(channel.schemaId);
    topics[channel.topic] = {
      schema: schema.name, schemaEncoding: schema.encoding, messageEncoding: channel.messageEncoding,
      count: 0, logTimes: [], publishTimes: [], messages: [], ordered: true,
    };
  }
  for await (const message of reader.readMessages({ validateCrcs: true })) {
    const channel = reader.channelsById.get(message.channelId);
    const entry = topics[channel.topic];
    const body = JSON.parse(decoder.decode(message.data));
    checkRequired(schemas.get(channel.schemaId).body, body, channel.topic);
    const last = entry.logTimes.at(-1);
    if (last !== undefined && BigInt(last) > message.logTime) entry.ordered = false;
    entry.count += 1;
    entry.logTimes.push(message.logTime.toString());
    entry.publishTimes.push(message.publishTime.toString());
    entry.messages.push(body);
  }
  const metadata = [];
  for await (const record of reader.readMetadata()) {
    metadata.push({ name: record.name, keys: [...record.metadata.keys()] });
  }
  const stats = reader.statistics;
  return {
    topics,
    metadata,
    metadataIndexNames: reader.metadataIndexes.map((m) => m.name),
    statistics: stats && {
      messageCount: stats.messageCount.toString(),
      messageStartTime: stats.messageStartTime.toString(),
      messageEndTime: stats.messageEndTime.toString(),
      chunkCount: stats.chunkCount,
    },
    chunkIndexes: reader.chunkIndexes.length,
  };
}

function streamed(bytes) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(bytes);
  const counts = {};
  for (let record; (record = reader.nextRecord()); ) {
    counts[record.type] = (counts[record.type] ?? 0) + 1;
  }
  return { done: reader.done(), counts };
}

const path = process.argv[2];
const bytes = new Uint8Array(await readFile(path));
process.stdout.write(JSON.stringify({ indexed: await indexed(bytes), stream: streamed(bytes) }));
