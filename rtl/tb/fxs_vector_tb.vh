// fxs_vector_tb.vh: the driver and checker every unit's testbench includes.
//
// The including module declares, before this include:
//   localparam integer IN_W   input data bits, OUT_W output data bits
//   reg  clk, rst_n, in_valid, out_ready; reg [IN_W-1:0] in_data;
//   wire in_ready, out_valid;             wire [OUT_W-1:0] out_data;
//   task show(input integer i, input [IN_W-1:0] in,
//             input [OUT_W-1:0] got, input [OUT_W-1:0] want)  (decodes fields)
//
// Vectors are streamed, one binary record per vector read with $fread when
// it is needed (files or named pipes; memory does not grow with the count,
// and the count is a plusarg, so a new count never means a new build):
//   inputs.bin    per vector {zero pad, index[31:0], input data}, big endian,
//                 IN_RB = ceil((32 + IN_W) / 8) bytes
//   expected.bin  per vector {zero pad, index[31:0], output data}, OUT_RB bytes
// Plusargs: +N=<count> (required, below 2^31), +FIRST=<index of the first
//   record> (a shard's start; indices are taken mod 2^32), +IN=<file>,
//   +EXP=<file>, +SEED=<n>, +STALL=<percent of cycles with valid or ready
//   low>, +TRACE=<file>, +DUMP=<file> (every output, in order, one hex line
//   each: what the RTL computed).
//
// A record that is short, has a non-zero pad or the wrong index, and a file
// with more than N records, are errors, never a silent pass. The output
// handshake is checked too: while valid_o && !ready_i the data must hold and
// valid must stay high, and no output may follow the N-th.
// Ends with the line `P passed, F failed`; defined FXS_FATAL_ON_FAIL, a run
// with F > 0 then ends in $fatal (a non-zero exit status: the FuseSoC core's
// sim target defines it).

localparam integer IN_RB = (32 + IN_W + 7) / 8;
localparam integer OUT_RB = (32 + OUT_W + 7) / 8;
localparam integer RING = 1024;

reg [8*IN_RB-1:0]  in_rec;
reg [8*OUT_RB-1:0] exp_rec;
reg [IN_W-1:0] in_ring [0:RING-1];
integer in_cycle [0:RING-1];
reg [OUT_W-1:0] held_data;
reg [IN_W-1:0] next_data;
reg [31:0] first, want_idx;
reg held, next_loaded, aborted;
integer proto, extra, drain, quiet;
integer n, stall, seed, in_idx, out_idx, passed, failed, cycle, lat_min, lat_max, nxt, r1, r2, got;
integer fd_in, fd_exp, dump_fd;
reg [8*1024-1:0] trace_file, dump_file, in_file, exp_file;

task abort_run(input integer failures);
  begin
    if (dump_fd != 0) $fclose(dump_fd);
    $display("%0d passed, %0d failed", passed, failures);
    aborted = 1'b1;
`ifdef FXS_FATAL_ON_FAIL
    if (failures != 0) $fatal(1, "%0d failed", failures);
`endif
    $finish;
  end
endtask

initial begin
  clk = 1'b0;
  rst_n = 1'b0;
  in_valid = 1'b0;
  out_ready = 1'b0;
  in_data = {IN_W{1'b0}};
  next_data = {IN_W{1'b0}};
  next_loaded = 1'b0;
  aborted = 1'b0;
  in_idx = 0;
  out_idx = 0;
  held = 1'b0;
  held_data = {OUT_W{1'b0}};
  proto = 0;
  extra = 0;
  drain = -1;
  quiet = 0;
  passed = 0;
  failed = 0;
  cycle = 0;
  lat_min = 1 << 30;
  lat_max = 0;
  dump_fd = 0;
  if (!$value$plusargs("N=%d", n)) begin
    $display("error: +N=<vector count> is required");
    abort_run(1);
  end
  if (n < 1) begin
    $display("error: +N=%0d: at least one vector", n);
    abort_run(1);
  end
  first = 32'd0;
  if ($value$plusargs("FIRST=%d", first)) begin end
  stall = 0;
  if ($value$plusargs("STALL=%d", stall)) begin end
  seed = 1;
  if ($value$plusargs("SEED=%d", seed)) begin end
  in_file = "inputs.bin";
  if ($value$plusargs("IN=%s", in_file)) begin end
  exp_file = "expected.bin";
  if ($value$plusargs("EXP=%s", exp_file)) begin end
  fd_in = $fopen(in_file, "rb");
  fd_exp = $fopen(exp_file, "rb");
  if (fd_in == 0 || fd_exp == 0) begin
    $display("error: cannot open the vector files (+IN, +EXP)");
    abort_run(n);
  end
  if ($value$plusargs("DUMP=%s", dump_file)) begin
    dump_fd = $fopen(dump_file, "w");
    if (dump_fd == 0) begin
      $display("error: cannot open +DUMP file");
      abort_run(n);
    end
  end
  if ($value$plusargs("TRACE=%s", trace_file)) begin
    $dumpfile(trace_file);
    $dumpvars(0);
  end
  $display("vectors streaming: %0d from index %0d", n, first);
  $fflush;
  repeat (3) @(posedge clk);
  rst_n = 1'b1;
end

always #5 clk = ~clk;

always @(posedge clk) begin
  cycle <= cycle + 1;
  if (rst_n && !aborted) begin
    // Input side: valid stays high until the transfer.
    nxt = in_idx;
    if (in_valid && in_ready) begin
      in_ring[in_idx % RING] = in_data;
      in_cycle[in_idx % RING] = cycle;
      nxt = in_idx + 1;
      next_loaded = 1'b0;
    end
    in_idx <= nxt;
    if (nxt - out_idx >= RING) begin
      $display("error: more than %0d vectors in flight", RING);
      abort_run(n - passed);
    end
    if (!in_valid || in_ready) begin
      if (nxt < n && !next_loaded) begin
        // Read vector nxt's record once, when it is first needed.
        got = $fread(in_rec, fd_in);
        want_idx = first + nxt;
        if (got != IN_RB) begin
          $display("error: %0s holds %0d of the %0d vectors (record %0d is %0d of %0d bytes)",
                   in_file, nxt, n, nxt, got < 0 ? 0 : got, IN_RB);
          abort_run(n - passed);
        end
        if ((in_rec >> IN_W) !== {{(8*IN_RB-32){1'b0}}, want_idx}) begin
          $display("error: %0s record %0d: index or pad wrong (want index %0d)",
                   in_file, nxt, want_idx);
          abort_run(n - passed);
        end
        next_data = in_rec[IN_W-1:0];
        next_loaded = 1'b1;
      end
      r1 = $random(seed);
      if (nxt < n && ((r1 & 32'h7fffffff) % 100) >= stall) begin
        in_valid <= 1'b1;
        in_data <= next_data;
      end else begin
        in_valid <= 1'b0;
      end
    end
    // Output handshake: data and valid hold while stalled.
    if (held) begin
      if (!out_valid || out_data !== held_data) begin
        proto = proto + 1;
        if (proto <= 5)
          $display("protocol error at cycle %0d: output %0d %s while valid_o && !ready_i",
                   cycle, out_idx, out_valid ? "data changed" : "valid dropped");
      end
    end
    held <= out_valid && !out_ready;
    held_data <= out_data;
    quiet = quiet + 1;
    // After the N-th output: any further output is one too many.
    if (drain >= 0) begin
      if (out_valid && out_ready) begin
        extra = extra + 1;
        if (extra <= 5) $display("error: an output beyond the %0d vectors at cycle %0d", n, cycle);
      end
      if (drain == 0) begin
        // Nothing may follow the N-th record in either file.
        got = $fread(in_rec, fd_in);
        if (got > 0) begin
          extra = extra + 1;
          $display("error: %0s holds more than %0d vectors", in_file, n);
        end
        got = $fread(exp_rec, fd_exp);
        if (got > 0) begin
          extra = extra + 1;
          $display("error: %0s holds more than %0d vectors", exp_file, n);
        end
        if (dump_fd != 0) $fclose(dump_fd);
        $display("%0d passed, %0d failed",
                 passed - ((proto + extra) > passed ? passed : (proto + extra)),
                 failed + proto + extra);
`ifdef FXS_FATAL_ON_FAIL
        if (failed + proto + extra != 0) $fatal(1, "%0d failed", failed + proto + extra);
`endif
        $finish;
      end
      drain = drain - 1;
    end else
    // Output side: compare every transfer, in order.
    if (out_valid && out_ready) begin
      quiet = 0;
      if (dump_fd != 0) $fwrite(dump_fd, "%h\n", out_data);
      got = $fread(exp_rec, fd_exp);
      want_idx = first + out_idx;
      if (got != OUT_RB) begin
        $display("error: %0s holds %0d of the %0d vectors (record %0d is %0d of %0d bytes)",
                 exp_file, out_idx, n, out_idx, got < 0 ? 0 : got, OUT_RB);
        abort_run(n - passed);
      end
      if ((exp_rec >> OUT_W) !== {{(8*OUT_RB-32){1'b0}}, want_idx}) begin
        $display("error: %0s record %0d: index or pad wrong (want index %0d)",
                 exp_file, out_idx, want_idx);
        abort_run(n - passed);
      end
      if (out_data === exp_rec[OUT_W-1:0]) begin
        passed = passed + 1;
      end else begin
        failed = failed + 1;
        if (failed <= 5)
          show(first + out_idx, in_ring[out_idx % RING], out_data, exp_rec[OUT_W-1:0]);
      end
      if (cycle - in_cycle[out_idx % RING] < lat_min) lat_min = cycle - in_cycle[out_idx % RING];
      if (cycle - in_cycle[out_idx % RING] > lat_max) lat_max = cycle - in_cycle[out_idx % RING];
      out_idx <= out_idx + 1;
      if (out_idx + 1 == n) begin
        $display("latency %0d cycles (min), %0d (max, with stalls)", lat_min, lat_max);
        $display("cycles %0d", cycle);
        // Keep reading for a while: nothing more may come out.
        drain = 64;
      end
    end
    r2 = $random(seed);
    out_ready <= (drain >= 0) || (((r2 & 32'h7fffffff) % 100) >= stall);
    // A stuck design: no output for this many cycles (stalls last a few).
    if (quiet > 100000) begin
      $display("error: no output for %0d cycles, %0d of %0d vectors out", quiet, out_idx, n);
      abort_run(n - passed);
    end
  end
end
