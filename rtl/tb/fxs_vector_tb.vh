// fxs_vector_tb.vh: the driver and checker every unit's testbench includes.
//
// The including module declares, before this include:
//   parameter  integer MAXN   vector memory depth (at least N + 1)
//   localparam integer IN_W   input data bits, OUT_W output data bits
//   reg  clk, rst_n, in_valid, out_ready; reg [IN_W-1:0] in_data;
//   wire in_ready, out_valid;             wire [OUT_W-1:0] out_data;
//   task show(input integer i, input [IN_W-1:0] in,
//             input [OUT_W-1:0] got, input [OUT_W-1:0] want)  (decodes fields)
//
// Files in the working directory (written by `fxshade vectors`):
//   inputs.hex    one line per vector: {index[31:0], input data}
//   expected.hex  one line per vector: {index[31:0], output data}
// Plusargs: +N=<count> (from the manifest; required), +SEED=<n>,
//   +STALL=<percent of cycles with valid or ready low>, +TRACE=<file>,
//   +DUMP=<file> (every output, in order, one hex line each: what the RTL
//   computed, for a caller that wants the results and not only the verdict).
//
// A vector file shorter or longer than N lines is an error (index fields and
// an untouched sentinel entry are checked), never a silent pass on
// uninitialised entries. Memory words are 32 bits wider than a line, so a
// line with extra leading digits (which $readmemh would truncate) and an
// extra line of any value (even all f) show in those bits.
// The output handshake is checked too: while valid_o && !ready_i the data
// must hold and valid must stay high, and no output may follow the N-th.
// Ends with the line `P passed, F failed`.

reg [64+IN_W-1:0]  in_mem  [0:MAXN];
reg [64+OUT_W-1:0] exp_mem [0:MAXN];
reg [OUT_W-1:0] held_data;
reg held;
integer proto, extra, drain;
integer in_cycle [0:MAXN];
integer n, stall, seed, in_idx, out_idx, passed, failed, cycle, lat_min, lat_max, i, bad, nxt, r1, r2;
reg [8*256-1:0] trace_file, dump_file;
integer dump_fd;

initial begin
  clk = 1'b0;
  rst_n = 1'b0;
  in_valid = 1'b0;
  out_ready = 1'b0;
  in_data = {IN_W{1'b0}};
  in_idx = 0;
  out_idx = 0;
  held = 1'b0;
  held_data = {OUT_W{1'b0}};
  proto = 0;
  extra = 0;
  drain = -1;
  passed = 0;
  failed = 0;
  cycle = 0;
  lat_min = 1 << 30;
  lat_max = 0;
  if (!$value$plusargs("N=%d", n)) begin
    $display("error: +N=<vector count> is required");
    $display("0 passed, 1 failed");
    $finish;
  end
  if (n + 1 > MAXN + 1 || n < 1) begin
    $display("error: +N=%0d outside 1..%0d (MAXN)", n, MAXN);
    $display("0 passed, %0d failed", n);
    $finish;
  end
  stall = 0;
  if ($value$plusargs("STALL=%d", stall)) begin end
  seed = 1;
  if ($value$plusargs("SEED=%d", seed)) begin end
  dump_fd = 0;
  if ($value$plusargs("DUMP=%s", dump_file)) begin
    dump_fd = $fopen(dump_file, "w");
    if (dump_fd == 0) begin
      $display("error: cannot open +DUMP file");
      $display("0 passed, %0d failed", n);
      $finish;
    end
  end
  if ($value$plusargs("TRACE=%s", trace_file)) begin
    $dumpfile(trace_file);
    $dumpvars(0);
  end
  for (i = 0; i <= MAXN; i = i + 1) begin
    in_mem[i] = {(64 + IN_W){1'b1}};
    exp_mem[i] = {(64 + OUT_W){1'b1}};
  end
  $readmemh("inputs.hex", in_mem);
  $readmemh("expected.hex", exp_mem);
  bad = 0;
  for (i = 0; i < n; i = i + 1) begin
    // The pad (top 32 bits) must be zero and the index field i.
    if (in_mem[i][64+IN_W-1:IN_W] !== {32'd0, i}) bad = bad + 1;
    if (exp_mem[i][64+OUT_W-1:OUT_W] !== {32'd0, i}) bad = bad + 1;
  end
  if (in_mem[n] !== {(64 + IN_W){1'b1}} || exp_mem[n] !== {(64 + OUT_W){1'b1}}) bad = bad + 1;
  if (bad != 0) begin
    $display("error: inputs.hex and expected.hex must hold exactly %0d vectors, indexed 0..%0d (%0d entries wrong)",
             n, n - 1, bad);
    $display("0 passed, %0d failed", n);
    $finish;
  end
  $display("vectors loaded: %0d", n);
  $fflush;
  repeat (3) @(posedge clk);
  rst_n = 1'b1;
end

always #5 clk = ~clk;

always @(posedge clk) begin
  cycle <= cycle + 1;
  if (rst_n) begin
    // Input side: valid stays high until the transfer.
    nxt = in_idx;
    if (in_valid && in_ready) begin
      in_cycle[in_idx] = cycle;
      nxt = in_idx + 1;
    end
    in_idx <= nxt;
    if (!in_valid || in_ready) begin
      r1 = $random(seed);
      if (nxt < n && ((r1 & 32'h7fffffff) % 100) >= stall) begin
        in_valid <= 1'b1;
        in_data <= in_mem[nxt][IN_W-1:0];
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
    // After the N-th output: any further output is one too many.
    if (drain >= 0) begin
      if (out_valid && out_ready) begin
        extra = extra + 1;
        if (extra <= 5) $display("error: an output beyond the %0d vectors at cycle %0d", n, cycle);
      end
      if (drain == 0) begin
        if (dump_fd != 0) $fclose(dump_fd);
        $display("%0d passed, %0d failed", passed - ((proto + extra) > passed ? passed : (proto + extra)),
                 failed + proto + extra);
        $finish;
      end
      drain = drain - 1;
    end else
    // Output side: compare every transfer, in order.
    if (out_valid && out_ready) begin
      if (dump_fd != 0) $fwrite(dump_fd, "%h\n", out_data);
      if (out_data === exp_mem[out_idx][OUT_W-1:0]) begin
        passed = passed + 1;
      end else begin
        failed = failed + 1;
        if (failed <= 5) show(out_idx, in_mem[out_idx][IN_W-1:0], out_data, exp_mem[out_idx][OUT_W-1:0]);
      end
      if (cycle - in_cycle[out_idx] < lat_min) lat_min = cycle - in_cycle[out_idx];
      if (cycle - in_cycle[out_idx] > lat_max) lat_max = cycle - in_cycle[out_idx];
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
    if (cycle > 100 + 50 * n) begin
      $display("error: timeout after %0d cycles with %0d of %0d vectors out", cycle, out_idx, n);
      $display("%0d passed, %0d failed", passed, n - passed);
      $finish;
    end
  end
end
