// Receives siteposed's poses over LCM with the generated Java classes
// (sitepose-dev: /usr/share/java/sitepose-lcmtypes.jar; LCM's own classes
// from liblcm-java) and prints one line per pose. Build and run against the
// installed packages:
//   javac -cp /usr/share/java/lcm.jar:/usr/share/java/sitepose-lcmtypes.jar PoseSubscriber.java
//   java -cp /usr/share/java/lcm.jar:/usr/share/java/sitepose-lcmtypes.jar:. PoseSubscriber
// Usage: PoseSubscriber [--count N] [--url URL] [--channel NAME]
// (as pose_subscriber.cpp).

import java.io.IOException;
import java.util.Locale;
import java.util.concurrent.CountDownLatch;
import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import sitepose.pose_t;

public class PoseSubscriber implements LCMSubscriber {
  private final long limit;
  private long received = 0;
  private final CountDownLatch done = new CountDownLatch(1);

  PoseSubscriber(long limit) {
    this.limit = limit;
  }

  @Override
  public synchronized void messageReceived(LCM lcm, String channel, LCMDataInputStream ins) {
    if (limit > 0 && received >= limit) return;  // main is about to exit
    try {
      pose_t m = new pose_t(ins);
      // Steer only on STATE_OK; FRAME_SITE: position is E, N, U in metres
      // from the site origin, lat/lon/height WGS84 (pose_t.lcm).
      System.out.println(String.format(Locale.ROOT,
          "pose seq=%d utime=%d state=%d frame=%d position=%.6f,%.6f,%.6f "
              + "orientation=%.6f,%.6f,%.6f,%.6f velocity=%.6f,%.6f,%.6f lat=%.9f lon=%.9f "
              + "height=%.4f heading=%.4f position_std=%.6f",
          m.seq, m.utime, m.state, m.frame, m.position[0], m.position[1], m.position[2],
          m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3], m.velocity[0],
          m.velocity[1], m.velocity[2], m.latitude_deg, m.longitude_deg, m.height_m, m.heading_deg,
          m.position_std_m));
      System.out.flush();
      if (limit > 0 && ++received >= limit) done.countDown();
    } catch (IOException e) {
      System.err.println(channel + ": " + e.getMessage());
    }
  }

  public static void main(String[] args) throws Exception {
    String url = null;
    String channel = "SITEPOSE_POSE";
    long count = 0;
    for (int i = 0; i + 1 < args.length; i += 2) {
      switch (args[i]) {
        case "--count": count = Long.parseLong(args[i + 1]); break;
        case "--url": url = args[i + 1]; break;
        case "--channel": channel = args[i + 1]; break;
        default:
          System.err.println("usage: PoseSubscriber [--count N] [--url URL] [--channel NAME]");
          System.exit(2);
      }
    }
    LCM lcm = url == null ? new LCM() : new LCM(url);
    PoseSubscriber subscriber = new PoseSubscriber(count);
    lcm.subscribe(channel, subscriber);
    subscriber.done.await();
    lcm.close();
    System.exit(0);
  }
}
